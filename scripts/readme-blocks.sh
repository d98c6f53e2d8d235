#!/usr/bin/env bash
# Runs the README's command blocks as written, on the project's own data, in a scratch folder
# (issue 39): the "five commands" block, the clinical block and the Python snippet, each line
# executed by bash (or Python) exactly as README.md has it; a block that fails fails this
# script. Every `dynaslice` command (and the Python snippet) runs under scripts/silence.py,
# which measures its longest silence between two output lines, read through a pipe as in a
# log; the table of them ends the run.
#
# The inputs the blocks name (labels.nii.gz, phases.seq, phase0.dcm, ct/) are made first from
# `dynaslice synth`'s chambers (scripts/readme-data.py; 2 mm voxels; the RT Structure Set
# phases written by `dynaslice rtstruct` from the first model), and `ct.dsm` by the README's
# own line `dynaslice train phases.seq -o ct.dsm` (from its "Other inputs" block).
#
# Environment:
#   DYNASLICE_BIN          the binary (default: built here with the test profile, as
#                          scripts/ci-probe.sh does)
#   DYNASLICE_README_STEPS when set, every `train` of the blocks runs with `--steps N` added:
#                          the one change to the commands as written, said on every such line
#                          (train's default, 3000 steps, is 8.6 minutes per model at the 5.8
#                          steps/s the README measured for the demo on the project's 2-core
#                          machine; .ci/run sets a short run). Unset: exactly as written.
#   DYNASLICE_PYTHON       a Python that imports the built `dynaslice` package (default: the
#                          venv dynaslice-python/ci.sh made, if any); without one the Python
#                          snippet is skipped with a notice, unless DYNASLICE_REQUIRE_PYTHON=1.
#   DYNASLICE_SILENCE_LIMIT when set, a command silent for longer (seconds) fails the run.
#   DYNASLICE_README_KEEP  a folder to run in and keep (default: a temporary one, removed).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
start=$(date +%s)
step() { echo; echo "=== readme: $* ($(( $(date +%s) - start ))s)"; }

if [ -n "${DYNASLICE_BIN:-}" ]; then
    bin=$(realpath "$DYNASLICE_BIN")
else
    cargo build --quiet --profile test -p dynaslice-cli --bin dynaslice
    bin="$root/target/debug/dynaslice"
fi
if [ -n "${DYNASLICE_README_KEEP:-}" ]; then
    work=$(realpath -m "$DYNASLICE_README_KEEP"); mkdir -p "$work"
else
    work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
fi
echo "binary $bin; working in $work"

# The blocks, by the section that holds them: the first ```sh (or ```python) block after it.
block() { # SECTION-HEADING-START LANGUAGE
    python3 - "$root/README.md" "$1" "$2" <<'PY'
import sys
text, heading, lang = open(sys.argv[1]).read().split("\n"), sys.argv[2], sys.argv[3]
at = next((i for i, l in enumerate(text) if l.startswith("## " + heading)), None)
if at is None:
    sys.exit("README.md has no section '## %s'" % heading)
for i in range(at + 1, len(text)):
    if text[i].startswith("## "):
        break
    if text[i].strip() == "```" + lang:
        end = text.index("```", i + 1)
        print("\n".join(text[i + 1:end]))
        sys.exit(0)
sys.exit("README.md's section '## %s' has no ```%s block" % (heading, lang))
PY
}
five=$(block "Your own data in five commands" sh)
clinical=$(block "Clinical answers" sh)
snippet=$(block "Your own data in five commands" python)
# The README's own line that trains ct.dsm from RT Structure Sets (the "Other inputs" block).
ct_train=$(python3 - "$root/README.md" <<'PY'
import sys
for line in open(sys.argv[1]):
    if line.startswith("dynaslice train phases.seq -o ct.dsm"):
        print(line.rstrip("\n")); break
else:
    sys.exit("README.md has no line 'dynaslice train phases.seq -o ct.dsm'")
PY
)

# `dynaslice` on the blocks' PATH: the binary under silence.py (and --steps where asked).
mkdir -p "$work/bin"
summary="$work/silences.tsv"; : >"$summary"
cat >"$work/bin/dynaslice" <<SH
#!/usr/bin/env bash
args=("\$@")
if [ "\${1:-}" = train ] && [ -n "\${DYNASLICE_README_STEPS:-}" ]; then
    args+=(--steps "\$DYNASLICE_README_STEPS")
    echo "readme: running with --steps \$DYNASLICE_README_STEPS added (DYNASLICE_README_STEPS)" >&2
fi
limit=()
[ -n "\${DYNASLICE_SILENCE_LIMIT:-}" ] && limit=(--limit "\$DYNASLICE_SILENCE_LIMIT")
exec python3 "$root/scripts/silence.py" --summary "$summary" "\${limit[@]}" --label "dynaslice \$*" -- "$bin" "\${args[@]}"
SH
chmod +x "$work/bin/dynaslice"
export PATH="$work/bin:$PATH"
cd "$work"

run_block() { # NAME TEXT
    step "$1"
    printf '%s\n' "$2" | sed 's/^/    /'
    echo
    printf '%s\n' "$2" >"$work/block.sh"
    bash -e -x "$work/block.sh"
}

step "the inputs: dynaslice synth's chambers, a CT series and an RT Structure Set of them"
"$bin" synth --shape chambers --timesteps 9 -o synth
python3 "$root/scripts/readme-data.py" synth/chambers/truth.nii.gz synth/chambers/labels.txt .

run_block "the five commands" "$five"

step "the RT Structure Set phases (phases.seq, phase0.dcm) from heart.dsm, for the clinical block"
dynaslice rtstruct heart.dsm --like seed.dcm --ct ct --times 0:1:4 -o phases
sed 's#^\([^ ]*\) #\1 phases/#' phases/rtstruct.seq >phases.seq
cp phases/RS_t000.dcm phase0.dcm
run_block "ct.dsm, by the README's line" "$ct_train"

run_block "the clinical block" "$clinical"

step "the Python snippet"
py="${DYNASLICE_PYTHON:-}"
if [ -z "$py" ] && [ -x "$root/dynaslice-python/.venv/bin/python" ]; then
    py="$root/dynaslice-python/.venv/bin/python"
fi
if [ -n "$py" ] && "$py" -c "import dynaslice" 2>/dev/null; then
    printf '%s\n' "$snippet" | sed 's/^/    /'
    printf '%s\n' "$snippet" >snippet.py
    limit=()
    [ -n "${DYNASLICE_SILENCE_LIMIT:-}" ] && limit=(--limit "$DYNASLICE_SILENCE_LIMIT")
    python3 "$root/scripts/silence.py" --summary "$summary" "${limit[@]}" --label "the Python snippet" -- "$py" snippet.py
elif [ "${DYNASLICE_REQUIRE_PYTHON:-0}" = 1 ]; then
    echo "no Python with the dynaslice package (DYNASLICE_PYTHON, or dynaslice-python/ci.sh's venv)" >&2
    exit 1
else
    echo "NOTE: no Python with the dynaslice package: the Python snippet is skipped"
fi

step "done; the longest silence of each command (seconds; seconds in all; command)"
sort -rn "$summary"
