#!/usr/bin/env bash
# The adversarial probe of issue 29, kept in CI: reruns its families against the built binary
# on small synthetic models and counts what must stay at zero.
#
#   hostile   a table of bad values per option (negative, NaN, inf, huge, empty, non-numeric,
#             out of range): each must be refused (exit 1 or 2) quickly;
#   pipes     a closed pipe, `| head -1` and /dev/full on stdout, /dev/full on stderr: no panic,
#             no success on a full stdout, and no output lost because stderr is full;
#   inputs    FIFOs and /dev/zero behind every input name (and inside a .seq and an NRRD's
#             `data file:`), under a time and a memory limit: refused, never read;
#   overwrite every output, sidecar, series file and link of every writing command already
#             there: refused without --force, checked by sha256 that nothing changed;
#   pairs     two runs on one -o at once (different models, so a mix shows): what is left
#             comes from one run, with no temporaries or lock files left over;
#   absurd    (issue 37) tiny and huge positive values (1e-30, 4294967297, 1e30) of spacings,
#             steps and tolerances of labels, measure, rtstruct, report, eval and bench:
#             refused before any work, nothing written;
#   corrupt   truncated and bit-flipped models, NIfTI, NRRD, JSON and RT Structure Sets as
#             inputs: refused, no panic;
#   demo      a user's folder with a model.dsm and labels.nii.gz: the demo refuses, nothing
#             changes;
#   fulldisk  every multi-file writer (mesh per class and series, labels NIfTI and .seg.nrrd,
#             measure --itv, rtstruct) on a small tmpfs of several sizes: success whole or
#             failure with the folder as it was (skipped with a note where mount is refused);
#   signals   SIGTERM mid-train then --resume: byte-identical to an uninterrupted run; SIGKILL
#             before the first checkpoint then a plain rerun; SIGTERM to labels: no lock file or
#             temporary left.
#   images    (issue 50) a CT-like image given where a label map belongs (int16 noise at
#             128×128×40 and 512×512×100) refused within 2 s saying it looks like an image;
#             6912 labels on a 24×24×12 grid refused within 1 s; one SIGTERM while contours are
#             traced ends train within 1 s leaving nothing; a user's file at a sidecar path
#             (MODEL.dsm.ckpt.loss.csv) refused without --force and untouched.
#
# Counts: panics (exit 101 or "panicked at"), crashes (killed by a signal other than the time
# limit's), hangs (killed by the time limit), nonsense (a bad value accepted, a non-finite
# number printed, success on a full stdout), replaced (files changed without --force), mixed
# (outputs of two runs together, leftovers), lost (an output missing after a run that had to
# write it), partial (a failed multi-file run that left new files or changed old ones), resume
# (a resumed run not byte-identical, or a killed run blocking a fresh start). Exit status 1 unless every count is 0; each failure is printed on one line.
#
# Environment: DYNASLICE_BIN (the binary; default: built here with the test profile),
# DYNASLICE_PROBE_SECONDS (limit per run, default 20), DYNASLICE_PROBE_INPUT_SECONDS (limit
# per run of the input family, default 5), DYNASLICE_PROBE_MEMORY_KB (virtual memory limit for
# the input family, default 1 GiB).
set -uo pipefail
cd "$(dirname "$0")/.."
if [ -n "${DYNASLICE_BIN:-}" ]; then
    bin=$(realpath "$DYNASLICE_BIN")
else
    cargo build --quiet --profile test -p dynaslice-cli --bin dynaslice || exit 1
    bin=$PWD/target/debug/dynaslice
fi
limit=${DYNASLICE_PROBE_SECONDS:-20}
memory_kb=${DYNASLICE_PROBE_MEMORY_KB:-1048576}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
started=$(date +%s)

panics=0 crashes=0 hangs=0 nonsense=0 replaced=0 mixed=0 lost=0 partial=0 resume=0 runs=0
fail() { # FAMILY COUNTER WHAT
    echo "FAIL [$1] $3"
    eval "$2=\$(( $2 + 1 ))"
}

# run [--memory] ARGS...: the binary with ARGS under the time limit (and the memory limit),
# stdin from /dev/null unless redirected by the caller, stdout to ./out, stderr to ./err; sets
# rc. Callers may redirect stdout/stderr of `run` itself through OUT and ERR.
OUT=out ERR=err
run() {
    local mem=unlimited
    if [ "$1" = --memory ]; then mem=$memory_kb; shift; fi
    runs=$((runs + 1))
    (ulimit -v "$mem"; exec timeout -k 2 "$limit" "$bin" "$@") </dev/null >"$OUT" 2>"$ERR"
    rc=$?
}

# check FAMILY EXPECT LABEL: classifies the last run; EXPECT is fail (a refusal is required)
# or ok (anything but a panic, crash or hang).
check() {
    local family=$1 expect=$2 label=$3
    if [ "$rc" = 101 ] || grep -qs "panicked at" "$ERR"; then
        fail "$family" panics "$label: panic (exit $rc): $(grep -hs -m1 panicked "$ERR")"
    elif [ "$rc" = 124 ] || [ "$rc" = 137 ]; then
        if [ "$family" = hostile ]; then
            fail "$family" nonsense "$label: accepted, still running after ${limit} s"
        else
            fail "$family" hangs "$label: still running after ${limit} s"
        fi
    elif [ "$rc" -gt 128 ]; then
        fail "$family" crashes "$label: killed by signal $((rc - 128)) $(tail -c 200 "$ERR" 2>/dev/null)"
    elif [ "$expect" = fail ] && [ "$rc" = 0 ]; then
        fail "$family" nonsense "$label: accepted (exit 0)"
    elif grep -Eqsi '(^|[^a-z])(nan|[+-]?inf)([^a-z]|$)' "$OUT" 2>/dev/null; then
        fail "$family" nonsense "$label: printed a non-finite number: $(grep -Eio -m1 '.{0,30}(nan|inf).{0,10}' "$OUT" | head -n 1 | tr -s ' ')"
    fi
}

# ---------------------------------------------------------------- the models and inputs
step() { echo "--- $* ($(( $(date +%s) - started )) s)"; }
step "models"
# 9 timesteps, annotated every 4th: 3 frames, so the models move and times are checked.
"$bin" synth --timesteps 9 --plane-resolution 32 --volume-resolution 16 -o synth >/dev/null 2>&1 \
    || { echo "cannot write the synthetic inputs"; exit 1; }
train_small() { # INPUT OUT
    "$bin" train "$1" -o "$2" --steps 20 --widths 16,16 --contour-samples 64 --plane-samples 64 \
        --space-samples 64 --threads 1 --force >/dev/null 2>&1
}
train_small synth/chambers/slices.json chambers.dsm && train_small synth/blob/slices.json blob.dsm \
    || { echo "cannot train the probe's models"; exit 1; }
M=$PWD/chambers.dsm
read -r t0 t1 < <("$bin" info "$M" | awk '/^time range/ {print $3, $5}')
tm=$(awk -v a="$t0" -v b="$t1" 'BEGIN {print (a + b) / 2}')
slices=$PWD/synth/chambers/slices.json
truth=$PWD/synth/chambers/truth.nii.gz

# ---------------------------------------------------------------- hostile option values
step "hostile option values"
numbers=(-1 nan NaN inf -inf 1e309 1e30 -1e30 99999999999999999999 "" abc 0x10 "1 2")
series=(0:1:0 0:1:-1 nan:1:2 0:inf:2 "0:$t1:99999999" 1e30:1e31:2 "$t1:$t0:2" 0:5:2 -1:1:2 "" abc 1:2)
probe_values() { # KIND ARGS... (V marks the value; KIND numbers or series)
    local kind=$1; shift
    local -n list=$kind
    local v a args
    for v in "${list[@]}"; do
        args=()
        for a in "$@"; do args+=("${a//@V@/$v}"); done
        rm -rf o; mkdir o
        run "${args[@]}"
        check hostile fail "$(printf '%q ' "${args[@]}")"
    done
}
probe_values numbers mesh "$M" --time @V@ -o o/t.ply --resolution 8
for opt in --resolution --safety --newton-steps --threads; do
    probe_values numbers mesh "$M" --time "$tm" "$opt" @V@ -o o/t.ply
done
probe_values series mesh "$M" --times @V@ -o o/s --resolution 8
for opt in --spacing --safety --threads; do
    probe_values numbers labels "$M" "$opt" @V@ -o o/l.nii.gz
done
probe_values numbers labels "$M" --bounds @V@,0,0,1,1,1 -o o/l.nii.gz
probe_values series labels "$M" --times @V@ --spacing 0.2 -o o/l.nii.gz
for opt in --resolution --size; do
    probe_values numbers picture --3d "$M" "$opt" @V@ -o o/p.png
done
probe_values numbers picture "$M" "$slices" --times @V@ -o o/p.png
probe_values numbers picture "$M" "$slices" --frame @V@ -o o/p.png
probe_values series eval volume "$M" --times @V@ --resolution 8 -o o/v.csv
probe_values numbers eval volume "$M" --resolution @V@ -o o/v.csv
for opt in --steps --lr --widths --omega0 --threads --seed --minutes --temporal-factor \
    --contour-samples --plane-samples --space-samples --checkpoint-minutes; do
    probe_values numbers train "$slices" "$opt" @V@ -o o/m.dsm
done
for i in 0 1 2 3; do
    xyzt=(0 0 0 "$tm")
    for v in nan inf -inf 1e309 1e9 -1e9 4294967297 1e30 1e38 abc ""; do
        xyzt[i]=$v
        run query "$M" -- "${xyzt[@]}"
        # Far finite points may be answered (with finite values) or refused; NaN never.
        if [[ $v =~ ^-?[0-9.e]+$ ]] && [ "$v" != 1e309 ]; then
            check hostile ok "query -- ${xyzt[*]}"
        else
            check hostile fail "query -- ${xyzt[*]}"
        fi
    done
done
for opt in --timesteps --planes --plane-resolution --volume-resolution --train-every; do
    probe_values numbers synth "$opt" @V@ -o o/s
done
for opt in --resolution --mesh-resolution --truth-resolution --samples; do
    probe_values numbers eval synthetic "$M" --shape chambers "$opt" @V@
done
probe_values numbers demo -o o/demo --resolution @V@
for v in 0 0,0 16,0 "" abc; do
    run demo -o o/demo --widths "$v"
    check hostile fail "demo --widths $v"
done
run demo -o o/demo --resolution 1
check hostile fail "demo --resolution 1"

# ---------------------------------------------------------------- pipes and full devices
step "closed pipes and full devices"
closed_pipe() { # ARGS: the binary with a stdout pipe whose reader is already gone
    runs=$((runs + 1))
    python3 - "$limit" "$bin" "$@" 2>"$ERR" >"$OUT" <<'PY'
import os, subprocess, sys
limit, args = float(sys.argv[1]), sys.argv[2:]
r, w = os.pipe()
os.close(r)
try:
    p = subprocess.run(args, stdin=subprocess.DEVNULL, stdout=w, stderr=sys.stderr, timeout=limit)
    code = p.returncode
except subprocess.TimeoutExpired:
    code = 124
sys.exit(code if code >= 0 else 128 - code)
PY
    rc=$?
}
printers=(
    "info $M"
    "query $M -- 0 0 0 $tm"
    "completions bash"
    "man"
    "--help"
    "eval volume $M --resolution 8 --times 0:$t1:2 -o o/v.csv --force"
    "eval synthetic $M --shape chambers --resolution 8 --mesh-resolution 8 --truth-resolution 8 --samples 100"
    "bench --widths 16,16 --repeats 1"
    "synth --timesteps 2 --plane-resolution 16 --volume-resolution 8 -o o/s --force"
)
for p in "${printers[@]}"; do
    read -r -a args <<<"$p"
    rm -rf o; mkdir o
    closed_pipe "${args[@]}"
    check pipes ok "$p >(closed pipe)"
    runs=$((runs + 1))
    rm -rf o; mkdir o
    (timeout -k 2 "$limit" "$bin" "${args[@]}" 2>"$ERR"; echo $? >rc) </dev/null | head -1 >/dev/null
    rc=$(cat rc)
    check pipes ok "$p | head -1"
    rm -rf o; mkdir o
    OUT=/dev/full run "${args[@]}"
    check pipes fail "$p >/dev/full"
done
# stderr full: no panic, and the output is still written.
writers=(
    "o/m.dsm|train $slices -o o/m.dsm --steps 20 --widths 16,16 --contour-samples 64 --plane-samples 64 --space-samples 64"
    "o/t.ply|mesh $M --time $tm --class 1 --resolution 8 -o o/t.ply"
    "o/l.nii.gz|labels $M --spacing 0.2 --times 0:$t1:2 -o o/l.nii.gz"
    "o/p.png|picture --3d $M --resolution 8 --size 96 -o o/p.png"
)
for w in "${writers[@]}"; do
    file=${w%%|*}
    read -r -a args <<<"${w#*|}"
    rm -rf o; mkdir o
    : >err # what stderr said is lost: only the exit status tells
    ERR=/dev/full run "${args[@]}"
    ERR=err check pipes ok "${w#*|} 2>/dev/full"
    [ -f "$file" ] || fail pipes lost "${w#*|} 2>/dev/full: no $file (exit $rc)"
done

# ---------------------------------------------------------------- FIFOs and devices as inputs
step "FIFOs and endless devices as inputs"
mkdir -p in
names=(a.csl a.nii a.nii.gz a.nrrd a.seg.nrrd a.dcm a.json a.seq a.dsm a.stl labels.txt)
for n in "${names[@]}"; do
    mkfifo "in/fifo_$n"
    ln -s /dev/zero "in/zero_$n"
done
mkfifo in/data.raw
printf 'NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: data.raw\n\n' >in/detached.nrrd
printf '0 %s\n' "$PWD/in/fifo_a.nii" >in/fifo_inside.seq
printf '0 %s\n' "$PWD/in/zero_a.nii" >in/zero_inside.seq
inputs=(in/fifo_* in/zero_* in/detached.nrrd in/fifo_inside.seq in/zero_inside.seq)
# A refusal is immediate: a reader that opens a FIFO blocks, so a short limit suffices.
saved_limit=$limit
limit=${DYNASLICE_PROBE_INPUT_SECONDS:-5}
for f in "${inputs[@]}"; do
    [ "$f" = in/fifo_data.raw ] && continue
    rm -rf o; mkdir o
    run --memory train "$f" -o o/m.dsm --steps 1
    check inputs fail "train $f"
    run --memory info "$f"
    check inputs fail "info $f"
    run --memory labels "$M" --like "$f" -o o/l.nii.gz
    check inputs fail "labels --like $f"
    run --memory picture "$M" "$f" -o o/p.png
    check inputs fail "picture MODEL $f"
    run --memory eval reference "$M" "$f" --time "$tm"
    check inputs fail "eval reference MODEL $f"
    # The .seq and NRRD texts above are valid label-name files; only the FIFOs and devices.
    case $f in *_inside.seq) continue ;; in/fifo_* | in/zero_*) ;; *) continue ;; esac
    run --memory train "$slices" --label-names "$f" -o o/m.dsm --steps 1
    check inputs fail "train --label-names $f"
done
limit=$saved_limit

# ---------------------------------------------------------------- overwrites without --force
step "overwrite attempts without --force"
digest() { # DIR: every entry's name, kind, link target and content
    (cd "$1" && find . -mindepth 1 -printf '%p %y %l\n' | sort &&
        find . -type f -print0 | sort -z | xargs -0 -r sha256sum)
}
# CASE: a command writing into ./w (@W@ stands for it) and the files it writes there.
overwrite_cases=(
    "mesh $M --time $tm --class 1 --resolution 8 -o @W@/t.ply"
    "mesh $M --time $tm --resolution 8 -o @W@/t.stl"
    "mesh $M --times 0:$t1:2 --resolution 8 -o @W@/series"
    "picture --3d $M --resolution 8 --size 96 -o @W@/p.png"
    "picture $M $slices -o @W@/p.png"
    "eval volume $M --times 0:$t1:2 --resolution 8 -o @W@/v.csv"
    "eval synthetic $M --shape chambers --resolution 8 --mesh-resolution 8 --truth-resolution 8 --samples 100 --csv @W@/e.csv"
    "labels $M --spacing 0.2 --times 0:$t1:2 -o @W@/l.nii.gz"
    "labels $M --spacing 0.2 --times 0:$t1:2 -o @W@/l.seg.nrrd"
    "train $slices -o @W@/m.dsm --steps 20 --widths 16,16 --contour-samples 64 --plane-samples 64 --space-samples 64"
    "eval split $truth --holdout-planes 3::4 -o @W@/split.json"
    "man -o @W@/man1"
    "synth --timesteps 2 --plane-resolution 16 --volume-resolution 8 -o @W@/s"
    "report $M --times 0:$t1:2 --resolution 8 -o @W@/r.html"
    "measure $M --times 0:$t1:2 --resolution 8 --itv @W@/itv -o @W@/m.csv"
)
echo "a user's reference" >reference.stl
for c in "${overwrite_cases[@]}"; do
    read -r -a template <<<"$c"
    rm -rf w; mkdir w
    args=("${template[@]//@W@/$PWD/w}")
    run "${args[@]}"
    if [ "$rc" != 0 ]; then
        fail overwrite lost "$c: the first run failed (exit $rc): $(tail -n 1 "$ERR")"
        continue
    fi
    mapfile -t written < <(cd w && find . -type f ! -name '.*' | sort)
    i=0
    for f in "${written[@]}"; do
        rm -rf w; mkdir w
        mkdir -p "w/$(dirname "$f")"
        case $((i % 3)) in
            0) echo "a user's file" >"w/$f" ;;
            1) ln -s "$PWD/reference.stl" "w/$f" ;;
            2) ln -s "$PWD/w/nowhere" "w/$f" ;;
        esac
        kind=$(case $((i % 3)) in 0) echo file ;; 1) echo link ;; 2) echo "dangling link" ;; esac)
        i=$((i + 1))
        before=$(digest w; sha256sum reference.stl)
        run "${args[@]}"
        after=$(digest w; sha256sum reference.stl)
        check overwrite fail "$c over an existing $f ($kind)"
        if [ "$before" != "$after" ]; then
            fail overwrite replaced "$c: changed the folder with an existing $f ($kind)"
        fi
    done
done

# ---------------------------------------------------------------- concurrent pairs
step "concurrent pairs on one -o"
B=$PWD/blob.dsm
# The label volumes of two models with different classes, on different grids: the volume's
# voxel size says which run wrote it, the colour table's names which run wrote that.
nifti_spacing() {
    python3 -c 'import gzip, struct, sys; h = gzip.open(sys.argv[1]).read(348); print(round(abs(struct.unpack("<f", h[80:84])[0]), 4))' "$1"
}
for round in 1 2 3 4; do
    rm -rf w; mkdir w
    (ERR=w/err.a OUT=/dev/null run labels "$M" --spacing 0.2 --times 0:$t1:2 --force -o w/l.nii.gz; echo "$rc" >w/rc.a) &
    (ERR=w/err.b OUT=/dev/null run labels "$B" --spacing 0.25 --times 0:$t1:2 --force -o w/l.nii.gz; echo "$rc" >w/rc.b) &
    wait
    runs=$((runs + 2))
    for r in a b; do
        rc=$(cat "w/rc.$r")
        ERR=w/err.$r OUT=/dev/null check pairs ok "labels pair $round ($r)"
        if [ "$rc" != 0 ] && ! grep -q "is writing this output" "w/err.$r"; then
            fail pairs lost "labels pair $round ($r) failed: $(tail -n 1 "w/err.$r")"
        fi
    done
    if [ ! -f w/l.nii.gz ]; then
        fail pairs lost "labels pair $round: no volume"
        continue
    fi
    spacing=$(nifti_spacing w/l.nii.gz)
    if grep -q chamber w/l.label.txt; then names=chambers; else names=blob; fi
    case "$spacing/$names" in
        0.2/chambers | 0.25/blob) ;;
        *) fail pairs mixed "labels pair $round: a volume of ${spacing} voxels with the $names table" ;;
    esac
    leftovers=$(cd w && ls -A | grep -v -E '^(l\.nii\.gz|l\.ctbl|l\.label\.txt|err\.[ab]|rc\.[ab])$' | tr '\n' ' ')
    [ -z "$leftovers" ] || fail pairs mixed "labels pair $round: left $leftovers"
done
# Two trainings of different inputs on one -o: the model, its checkpoint and loss log from
# one run (sizes differ with the class count; each run's own sizes measured alone first).
train_args=(--steps 20 --widths 16,16 --contour-samples 64 --plane-samples 64 --space-samples 64 --threads 1 --force)
sizes() { stat -c %s "$1/m.dsm" "$1/m.dsm.ckpt" 2>/dev/null | tr '\n' ' '; }
for r in chambers blob; do
    rm -rf "solo_$r"; mkdir "solo_$r"
    "$bin" train "synth/$r/slices.json" -o "solo_$r/m.dsm" "${train_args[@]}" >/dev/null 2>&1
    eval "solo_$r=\"\$(sizes solo_$r)\""
done
for round in 1 2 3 4; do
    rm -rf w; mkdir w
    for r in chambers blob; do
        (ERR=w/err.$r OUT=/dev/null run train "synth/$r/slices.json" -o w/m.dsm "${train_args[@]}"; echo "$rc" >w/rc.$r) &
    done
    wait
    runs=$((runs + 2))
    for r in chambers blob; do
        rc=$(cat "w/rc.$r")
        ERR=w/err.$r OUT=/dev/null check pairs ok "train pair $round ($r)"
        if [ "$rc" != 0 ] && ! grep -q "is writing this output" "w/err.$r"; then
            fail pairs lost "train pair $round ($r) failed: $(tail -n 1 "w/err.$r")"
        fi
    done
    got=$(sizes w)
    if [ "$got" != "$solo_chambers" ] && [ "$got" != "$solo_blob" ]; then
        fail pairs mixed "train pair $round: model and checkpoint sizes $got are neither run's ($solo_chambers / $solo_blob)"
    fi
    leftovers=$(cd w && ls -A | grep -v -E '^(m\.dsm(\.ckpt|\.loss\.csv|\.loss\.png|\.ckpt\.loss\.csv)?|err\.[a-z]+|rc\.[a-z]+)$' | tr '\n' ' ')
    [ -z "$leftovers" ] || fail pairs mixed "train pair $round: left $leftovers"
done

# ---------------------------------------------------------------- absurd values (issue 37)
step "tiny and huge values"
tiny=(1e-30 1e-300 4294967297 1e30)
probe_values tiny labels "$M" --spacing @V@ -o o/l.nii.gz
probe_values tiny measure "$M" --times 0:$t1:2 --resolution 8 --itv o/itv --itv-spacing @V@ -o o/m.csv
probe_values tiny rtstruct "$M" --like nowhere.dcm --times 0:$t1:2 --step @V@ -o o/rs
for v in 1e30 4294967297 -1 nan; do
    rm -rf o; mkdir o
    run rtstruct "$M" --like nowhere.dcm --times 0:$t1:2 --tolerance "$v" -o o/rs
    check hostile fail "rtstruct --tolerance $v"
done
probe_values numbers report "$M" --resolution @V@ -o o/r.html
probe_values series report "$M" --times @V@ --resolution 8 -o o/r.html
probe_values series measure "$M" --times @V@ --resolution 8
probe_values numbers measure "$M" --resolution @V@
probe_values numbers eval reference "$M" "$truth" --time @V@
probe_values numbers eval heldout "$M" "$slices" --pixels @V@
for opt in --repeats --classes --threads; do
    probe_values numbers bench --widths 16,16 "$opt" @V@
done
# What each refusal above left: nothing.
[ -z "$(ls -A o 2>/dev/null)" ] || fail hostile nonsense "a refused run left $(ls -A o | tr '\n' ' ')"

# ---------------------------------------------------------------- corrupted inputs
step "corrupted inputs"
mkdir -p bad
"$bin" labels "$M" --spacing 0.2 --times 0:$t1:2 -o bad/ok.nii.gz >/dev/null 2>&1
"$bin" labels "$M" --spacing 0.2 --times 0:$t1:1 -o bad/ok.seg.nrrd >/dev/null 2>&1
cp "$M" bad/ok.dsm
cp "$slices" bad/ok.json
for f in bad/ok.*; do
    [ -f "$f" ] || continue
    ext=${f#bad/ok}
    size=$(stat -c %s "$f")
    head -c $((size / 2)) "$f" >"bad/half$ext"
    cp "$f" "bad/flip$ext"
    # Bytes flipped in the middle and near the start (headers).
    for at in $((size / 2)) 40 100; do
        [ "$at" -lt "$size" ] && printf '\xff\x00\xa5' | dd of="bad/flip$ext" bs=1 seek="$at" conv=notrunc status=none
    done
done
for f in bad/half.* bad/flip.*; do
    rm -rf o; mkdir o
    case $f in
        *.dsm) run info "$f"; check corrupt ok "info $f"
               run mesh "$f" --time "$tm" --resolution 8 -o o/t.ply; check corrupt ok "mesh $f" ;;
        *) run train "$f" -o o/m.dsm --steps 1 --widths 8; check corrupt ok "train $f"
           run labels "$M" --like "$f" -o o/l.nii.gz; check corrupt ok "labels --like $f" ;;
    esac
done

# ---------------------------------------------------------------- the demo and a user's folder
step "demo into a user's folder"
rm -rf mine; mkdir mine
echo "the user's model" >mine/model.dsm
echo "the user's labels" >mine/labels.nii.gz
before=$(digest mine)
run demo -o mine --steps 1 --resolution 16 --widths 16,16
check demo fail "demo -o a folder holding a user's model.dsm and labels.nii.gz"
[ "$before" = "$(digest mine)" ] || fail demo replaced "demo -o a user's folder changed it"

# ---------------------------------------------------------------- RT Structure Sets
step "RT Structure Sets"
# A CT series and a structure set in the probe model's frame (plain units read as mm: the
# domain is about 2.3 wide), made with pydicom where it is installed.
rt_ok=0
if python3 - rt <<'PY' >/dev/null 2>&1
import os, sys
import numpy as np
from pydicom.dataset import Dataset, FileDataset, FileMetaDataset
from pydicom.sequence import Sequence
from pydicom.uid import ExplicitVRLittleEndian, generate_uid
out = sys.argv[1]
for d in ("ct", "ct_same"):
    os.makedirs(os.path.join(out, d), exist_ok=True)
study, frame, series = generate_uid(), generate_uid(), generate_uid()
def base(path, cls):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID, meta.MediaStorageSOPInstanceUID = cls, generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = FileDataset(path, {}, file_meta=meta, preamble=b"\0" * 128)
    ds.SOPClassUID, ds.SOPInstanceUID, ds.StudyInstanceUID = cls, meta.MediaStorageSOPInstanceUID, study
    return ds
for d, same in (("ct", False), ("ct_same", True)):
    for k, z in enumerate(np.arange(-1.0, 1.01, 0.1)):
        path = os.path.join(out, d, "CT_%02d.dcm" % k)
        ds = base(path, "1.2.840.10008.5.1.4.1.1.2")
        ds.Modality, ds.SeriesInstanceUID, ds.FrameOfReferenceUID = "CT", series, frame
        ds.ImagePositionPatient = [-1.1, -1.1, 0.0 if same else float(z)]
        ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.PixelSpacing, ds.Rows, ds.Columns = [0.05, 0.05], 45, 45
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 1
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.PixelData = np.zeros((45, 45), np.int16).tobytes()
        ds.save_as(path, enforce_file_format=True)
path = os.path.join(out, "rs.dcm")
ds = base(path, "1.2.840.10008.5.1.4.1.1.481.3")
ds.Modality, ds.StructureSetLabel = "RTSTRUCT", "probe"
ref = Dataset(); ref.FrameOfReferenceUID = frame
ds.ReferencedFrameOfReferenceSequence = Sequence([ref])
roi = Dataset(); roi.ROINumber, roi.ROIName, roi.ReferencedFrameOfReferenceUID = 1, "chamber a", frame
roi.ROIGenerationAlgorithm = "MANUAL"
ds.StructureSetROISequence = Sequence([roi])
c = Dataset(); c.ReferencedROINumber, c.ROIDisplayColor = 1, [255, 0, 0]
it = Dataset(); it.ContourGeometricType, it.NumberOfContourPoints = "CLOSED_PLANAR", 4
it.ContourData = [-0.5, -0.5, 0.0, 0.5, -0.5, 0.0, 0.5, 0.5, 0.0, -0.5, 0.5, 0.0]
c.ContourSequence = Sequence([it])
ds.ROIContourSequence = Sequence([c])
ds.save_as(path, enforce_file_format=True)
PY
then
    rt_ok=1
    rs=(rtstruct "$M" --like rt/rs.dcm --times 0:$t1:2 --step 0.05)
    rm -rf o; mkdir o
    run "${rs[@]}" --ct rt/ct -o o/rs
    check rtstruct ok "rtstruct --ct"
    [ "$rc" = 0 ] && [ -f o/rs/rtstruct.seq ] || fail rtstruct lost "rtstruct --ct: no rtstruct.seq (exit $rc): $(tail -n 1 "$ERR")"
    rm -rf o; mkdir o
    run "${rs[@]}" --ct rt/ct_same -o o/rs
    check rtstruct fail "rtstruct --ct with every slice at one position"
    grep -q "CT_" "$ERR" || fail rtstruct nonsense "the repeated slice positions are not named: $(tail -n 1 "$ERR")"
    [ -z "$(ls -A o)" ] || fail rtstruct partial "a refused rtstruct left $(ls -A o | tr '\n' ' ')"
else
    echo "NOTE: pydicom missing: the RT Structure Set family is skipped"
fi

# ---------------------------------------------------------------- full disk (issue 37)
step "multi-file outputs on a full disk"
multi=(
    "mesh $M --time $tm --resolution 8 -o @W@/t.stl"
    "mesh $M --times 0:$t1:3 --resolution 8 -o @W@/series"
    "labels $M --spacing 0.1 --times 0:$t1:3 -o @W@/l.nii.gz"
    "labels $M --spacing 0.1 --times 0:$t1:3 -o @W@/l.seg.nrrd"
    "measure $M --times 0:$t1:2 --resolution 8 --itv @W@/itv"
)
[ "$rt_ok" = 1 ] && multi+=("rtstruct $M --like $PWD/rt/rs.dcm --ct $PWD/rt/ct --times 0:$t1:3 --step 0.05 -o @W@/rs")
mkdir -p disk
if mount -t tmpfs -o size=4k tmpfs disk 2>/dev/null; then
    umount disk
    full=0 whole=0
    for c in "${multi[@]}"; do
        read -r -a template <<<"$c"
        rm -rf w; mkdir w
        run "${template[@]//@W@/$PWD/w}"
        [ "$rc" = 0 ] || { fail fulldisk lost "$c: failed on an ordinary disk: $(tail -n 1 "$ERR")"; continue; }
        pages=$(find w -type f -printf '%s\n' | awk '{p += int(($1 + 4095) / 4096)} END {print p}')
        # Sizes from one page to past the whole output (lock files take pages too), at most 12.
        top=$((pages + 8))
        stride=$(( (top + 11) / 12 )); [ "$stride" -ge 1 ] || stride=1
        for ((n = 1; n <= top; n += stride)); do
            mount -t tmpfs -o size=$((4 * n))k tmpfs disk || break
            run "${template[@]//@W@/$PWD/disk}"
            check fulldisk ok "$c on $n pages"
            if [ "$rc" = 0 ]; then whole=$((whole + 1)); else full=$((full + 1)); fi
            if [ "$rc" != 0 ]; then
                left=$(ls -A disk | tr '\n' ' ')
                [ -z "$left" ] || fail fulldisk partial "$c on a disk of $n pages failed and left $left"
                grep -q "No space left" "$ERR" || fail fulldisk nonsense "$c on $n pages: $(tail -n 1 "$ERR")"
            fi
            umount disk
        done
    done
    echo "full disk: $full runs failed for lack of space, $whole had room"
    [ "$full" -gt 0 ] || fail fulldisk nonsense "no run ran out of space: the disk sizes did not span the outputs"
else
    echo "NOTE: cannot mount a tmpfs (not root?): the full-disk family is skipped"
fi

# ---------------------------------------------------------------- signals mid-run (issue 37)
step "SIGTERM, SIGHUP and SIGKILL mid-run"
sig_args=(--steps 1500 --widths 16,16 --contour-samples 64 --plane-samples 64 --space-samples 64 --threads 1 --checkpoint-minutes 0)
rm -rf sig; mkdir sig
"$bin" train "$slices" -o sig/ref.dsm "${sig_args[@]}" >/dev/null 2>&1
for s in TERM HUP; do
    rm -f sig/r.dsm*
    "$bin" train "$slices" -o sig/r.dsm "${sig_args[@]}" >/dev/null 2>sig/err &
    pid=$!
    # Stopped once training has begun (its journal has rows), so a checkpoint is due.
    for _ in $(seq 100); do [ "$(wc -l 2>/dev/null <sig/r.dsm.ckpt.loss.csv || echo 0)" -gt 5 ] && break; sleep 0.1; done
    kill -$s $pid; wait $pid; rc=$?
    runs=$((runs + 2))
    ERR=sig/err check signals ok "train, SIG$s mid-run"
    if [ "$rc" = 0 ]; then
        echo "NOTE: train finished before SIG$s"
    else
        leftovers=$(cd sig && ls -A | grep -E '^\.' | tr '\n' ' ')
        [ -z "$leftovers" ] || fail signals mixed "train after SIG$s left $leftovers"
        "$bin" train "$slices" -o sig/r.dsm "${sig_args[@]}" --resume >/dev/null 2>sig/err2
        cmp -s sig/ref.dsm sig/r.dsm && cmp -s sig/ref.dsm.loss.csv sig/r.dsm.loss.csv ||
            fail signals resume "SIG$s then --resume: not byte-identical to an uninterrupted run ($(tail -n 1 sig/err2))"
    fi
done
rm -f sig/r.dsm*
"$bin" train "$slices" -o sig/r.dsm --steps 100000 --widths 16,16 --threads 1 >/dev/null 2>&1 &
pid=$!
for _ in $(seq 100); do [ -s sig/r.dsm.ckpt.loss.csv ] && break; sleep 0.1; done
kill -KILL $pid; wait $pid 2>/dev/null
runs=$((runs + 2))
timeout -k 2 "$limit" "$bin" train "$slices" -o sig/r.dsm --steps 2 --widths 16,16 --threads 1 >/dev/null 2>sig/err
[ $? = 0 ] || fail signals resume "a plain rerun after SIGKILL before the first checkpoint: $(tail -n 1 sig/err)"
rm -rf w; mkdir w
"$bin" labels "$M" --spacing 0.01 --times 0:$t1:4 -o w/l.seg.nrrd >/dev/null 2>&1 &
pid=$!
sleep 1.5; kill -TERM $pid; wait $pid; rc=$?
runs=$((runs + 1))
[ "$rc" = 0 ] || [ -z "$(ls -A w)" ] || fail signals partial "labels after SIGTERM left $(ls -A w | tr '\n' ' ')"

# ---------------------------------------------------------------- images as label maps (issue 50)
step "images given as label maps"
# NIfTI-1 files written by hand (no NumPy needed): DIMS, TYPE (int16 noise or int32 labels
# 1..N, every voxel its own label, shuffled), 2 × 2 × 3 mm voxels.
make_nifti() { # OUT NX NY NZ noise|labels|blobs
    python3 - "$@" <<'PY'
import os, random, struct, sys
from array import array
out, nx, ny, nz, kind = sys.argv[1], *map(int, sys.argv[2:5]), sys.argv[5]
n = nx * ny * nz
if kind == "noise":
    datatype, bitpix, data = 4, 16, os.urandom(2 * n)
elif kind == "labels":
    values = list(range(1, n + 1))
    random.Random(0).shuffle(values)
    datatype, bitpix, data = 8, 32, array("i", values).tobytes()
else:  # 60 labels, each voxel drawn at random: slow to trace, within a model's 64 classes
    r = random.Random(0)
    datatype, bitpix, data = 2, 8, bytes(r.randrange(61) for _ in range(n))
h = bytearray(348)
struct.pack_into("<i", h, 0, 348)
struct.pack_into("<8h", h, 40, 3, nx, ny, nz, 1, 1, 1, 1)
struct.pack_into("<2h", h, 70, datatype, bitpix)
struct.pack_into("<8f", h, 76, 1, 2, 2, 3, 1, 1, 1, 1)
struct.pack_into("<f", h, 108, 352)
h[123] = 2  # millimetres
h[344:348] = b"n+1\0"
with open(out, "wb") as f:
    f.write(bytes(h) + bytes(4) + data)
PY
}
mkdir -p img
make_nifti img/ct_small.nii 128 128 40 noise && make_nifti img/ct_large.nii 512 512 100 noise \
    && make_nifti img/labels.nii 24 24 12 labels && make_nifti img/blobs.nii 96 96 64 blobs \
    || { echo "cannot write the issue-50 volumes"; exit 1; }
saved_limit=$limit
# Hang limits, generous next to the refusal's fraction of a second; the old behaviour took
# minutes (tracing every value's contours before the class limit was checked).
for c in "2 img/ct_small.nii image" "2 img/ct_large.nii image" "1 img/labels.nii classes"; do
    read -r limit input want <<<"$c"
    rm -rf o; mkdir o
    run train "$input" -o o/m.dsm --steps 3
    check images fail "train $input (an image for a label map)"
    case $want in
        image) grep -q "seems to be an image" "$ERR" ||
            fail images nonsense "train $input: not said to look like an image: $(tail -n 1 "$ERR")" ;;
        *) grep -q "a model holds at most 64 classes" "$ERR" ||
            fail images nonsense "train $input: no class count: $(tail -n 1 "$ERR")" ;;
    esac
    [ -z "$(ls -A o)" ] || fail images partial "train $input refused and left $(ls -A o | tr '\n' ' ')"
done
limit=$saved_limit
# One SIGTERM while the contours of a 60-label map are traced (seconds of work): the run ends
# within 1 s, says nothing was trained and leaves nothing (no model, lock file or journal).
rm -rf o; mkdir -p o sig
"$bin" train img/blobs.nii -o o/m.dsm --steps 3 >/dev/null 2>sig/err &
pid=$!
for _ in $(seq 50); do grep -q "^reading" sig/err 2>/dev/null && break; sleep 0.1; done
sleep 0.5
kill -TERM $pid
sent=$(date +%s%N)
for _ in $(seq 20); do kill -0 $pid 2>/dev/null || break; sleep 0.05; done
took=$(( ($(date +%s%N) - sent) / 1000000 ))
if kill -0 $pid 2>/dev/null; then
    fail signals hangs "train: still running ${took} ms after one SIGTERM while tracing"
    kill -KILL $pid
fi
wait $pid; rc=$?
runs=$((runs + 1))
[ "$rc" = 130 ] || fail signals nonsense "train: exit $rc after one SIGTERM while tracing (130 expected): $(tail -n 1 sig/err)"
grep -q "nothing was trained" sig/err || fail signals nonsense "train: SIGTERM while tracing: $(tail -n 1 sig/err)"
[ -z "$(ls -A o)" ] || fail signals partial "train after SIGTERM while tracing left $(ls -A o | tr '\n' ' ')"
# A user's file at the loss journal's path, with no checkpoint beside it: refused, untouched.
rm -rf w; mkdir w
echo "a user's file" >w/m.dsm.ckpt.loss.csv
before=$(digest w)
run train "$slices" -o w/m.dsm --steps 20 --widths 16,16 --contour-samples 64 --plane-samples 64 --space-samples 64
check overwrite fail "train over a user's m.dsm.ckpt.loss.csv"
[ "$before" = "$(digest w)" ] || fail overwrite replaced "train changed a user's m.dsm.ckpt.loss.csv without --force"

step "done"
echo "probe: $runs runs in $(( $(date +%s) - started )) s: $panics panics, $crashes crashes, $hangs hangs, $nonsense accepted nonsense, $replaced files replaced without --force, $mixed mixed outputs, $lost lost outputs, $partial partial multi-file outputs, $resume failed resumes"
[ $((panics + crashes + hangs + nonsense + replaced + mixed + lost + partial + resume)) = 0 ]
