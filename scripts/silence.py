#!/usr/bin/env python3
"""Runs a command and measures its longest silence: the most seconds between two lines it
prints (counting its start and its end as lines), the "never silent for more than 5 s" rule of
issue 39. Standard error is read through a pipe, as in a log (each line or carriage-return
update of a progress bar counts); standard output too, unless it goes to a regular file (then
the user sees none of it and it counts for nothing). Both are passed on unchanged.

    silence.py [--label TEXT] [--summary FILE] [--limit SECONDS] -- COMMAND ARGS...

Prints `silence: LONGEST s (after "LINE") in TEXT` on standard error at the end, then every
silence over 5.5 s with the line before it (`silence over 5 s: …`), appends
`LONGEST<TAB>TEXT` to FILE when given, and exits with the command's status; with --limit a
longer silence is an error (status 3) where the command itself succeeded.
"""
import argparse
import os
import selectors
import stat
import subprocess
import sys
import time

# Silences listed one by one: over 5 s, the rule, with 0.5 s for the scheduling of a progress
# ticker that prints every 4 s (dynaslice-cli's progress.rs) on a loaded machine.
OVER = 5.5


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--label")
    ap.add_argument("--summary")
    ap.add_argument("--limit", type=float)
    ap.add_argument("command", nargs=argparse.REMAINDER)
    a = ap.parse_args()
    cmd = a.command[1:] if a.command[:1] == ["--"] else a.command
    if not cmd:
        ap.error("no command")
    label = a.label or " ".join(cmd)
    to_file = stat.S_ISREG(os.fstat(1).st_mode)
    child = subprocess.Popen(cmd, stdout=None if to_file else subprocess.PIPE,
                             stderr=subprocess.PIPE)
    sel = selectors.DefaultSelector()
    sel.register(child.stderr, selectors.EVENT_READ, 2)
    if child.stdout is not None:
        sel.register(child.stdout, selectors.EVENT_READ, 1)
    last = start = time.monotonic()
    longest, after, previous = 0.0, "(the start)", "(the start)"
    over = []  # (seconds, the line before) of every silence over OVER
    partial = {1: b"", 2: b""}
    open_streams = len(sel.get_map())
    while open_streams:
        for key, _ in sel.select():
            data = os.read(key.fileobj.fileno(), 65536)
            fd = key.data
            if not data:
                sel.unregister(key.fileobj)
                open_streams -= 1
                continue
            os.write(fd, data)
            # A line ends at \n or at a progress bar's \r.
            text = partial[fd] + data
            pieces = text.replace(b"\r", b"\n").split(b"\n")
            partial[fd] = pieces[-1]
            if len(pieces) > 1:
                now = time.monotonic()
                if now - last > longest:
                    longest, after = now - last, previous
                if now - last > OVER:
                    over.append((now - last, previous))
                last = now
                done = [p for p in pieces[:-1] if p.strip()]
                if done:
                    previous = done[-1].decode("utf-8", "replace").strip()[:100]
    rc = child.wait()
    now = time.monotonic()
    if now - last > longest:
        longest, after = now - last, previous + " (to the end)"
    if now - last > OVER:
        over.append((now - last, previous + " (to the end)"))
    sys.stderr.write('silence: %.1f s (after "%s") in %s; %.0f s in all\n'
                     % (longest, after, label, now - start))
    for seconds, line in over:
        sys.stderr.write('silence over 5 s: %.1f s after "%s"\n' % (seconds, line))
    if a.summary:
        with open(a.summary, "a") as f:
            f.write("%.1f\t%.0f\t%s\n" % (longest, now - start, label))
    if rc == 0 and a.limit is not None and longest > a.limit:
        sys.stderr.write("silence: %.1f s is longer than %.0f s\n" % (longest, a.limit))
        return 3
    return rc


if __name__ == "__main__":
    sys.exit(main())
