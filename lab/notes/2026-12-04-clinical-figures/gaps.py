"""Longest silences in a timestamped log (ts.py's "SECONDS line" format): the gaps between
consecutive lines, with the demo step ($ line) they fell in.  python3 gaps.py LOG [N]"""
import sys
rows, step = [], "(before the first step)"
for l in open(sys.argv[1]):
    parts = l.split(None, 1)
    try:
        t = float(parts[0])
    except (ValueError, IndexError):
        continue
    text = parts[1].rstrip("\n") if len(parts) > 1 else ""
    if text.startswith("$ dynaslice"):
        step = text[2:60]
    rows.append((t, step, text))
gaps = sorted(((b[0] - a[0], a, b) for a, b in zip(rows, rows[1:])), key=lambda g: -g[0])
n = int(sys.argv[2]) if len(sys.argv) > 2 else 5
for g, a, b in gaps[:n]:
    print(f"{g:6.1f} s silent, {a[0]:.1f}..{b[0]:.1f} s, in `{b[1]}`: after {a[2][:90]!r}, before {b[2][:90]!r}")
print("total", rows[-1][0], "s over", len(rows), "lines")
