#!/usr/bin/env bash
# Fuzzes every input reader for a bounded time (docs/robustness.md, "Fuzzing"):
#   model files (from_bytes, from_bytes_crc), NIfTI, NRRD, RT Structure Sets, .csl, native
#   JSON, sequence manifests, label tables and training checkpoints: the targets of fuzz/.
#
# 1. installs what it needs on a fresh machine: a nightly toolchain (rustup, minimal profile)
#    and cargo-fuzz (`cargo install cargo-fuzz --locked`) when missing;
# 2. builds every target once with AddressSanitizer, debug assertions and overflow checks
#    (`cargo +nightly fuzz build`, release optimisation); if ASan alone cannot build, builds
#    without a sanitizer (`-s none`, debug assertions kept) and says so in a NOTE;
# 3. runs each target for DYNASLICE_FUZZ_SECONDS_PER_TARGET seconds from its seeds (each
#    target writes its own, checked, into fuzz/corpus/TARGET: DYNASLICE_FUZZ_SEEDS), up to
#    DYNASLICE_FUZZ_JOBS targets at a time, and prints per target the executions, their rate,
#    coverage and corpus size.
#
# Exits non-zero when a target crashes (panic, failed check, sanitizer report), runs one input
# for more than DYNASLICE_FUZZ_INPUT_TIMEOUT seconds or allocates more than 2 GiB (libFuzzer's
# -rss_limit_mb / -malloc_limit_mb); the reproducer is saved as fuzz/artifacts/TARGET/crash-*
# (or timeout-*, oom-*) and its last log lines are printed. Reproduce with
#   cd fuzz && cargo +nightly fuzz run TARGET artifacts/TARGET/crash-...
#
# Environment:
#   DYNASLICE_FUZZ_SECONDS_PER_TARGET  seconds per target (default 30; 0 builds and checks the
#                                      seeds only, by running each target over them once)
#   DYNASLICE_FUZZ_JOBS                targets fuzzed at once (default: the number of cores)
#   DYNASLICE_FUZZ_TARGETS             space-separated subset of targets (default: all)
#   DYNASLICE_FUZZ_INPUT_TIMEOUT       seconds one input may take (default 10)
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TERM_COLOR=never

start=$(date +%s)
step() { echo; echo "=== ci-fuzz: $* ($(($(date +%s) - start))s)"; }
fail() { echo "ci-fuzz: FAIL: $*" >&2; exit 1; }
note() { echo "ci-fuzz: NOTE: $*"; }

ALL_TARGETS="from_bytes_crc from_bytes nifti nrrd rtstruct csl native_json manifest label_table checkpoint"
secs=${DYNASLICE_FUZZ_SECONDS_PER_TARGET:-30}
jobs=${DYNASLICE_FUZZ_JOBS:-$(nproc)}
targets=${DYNASLICE_FUZZ_TARGETS:-$ALL_TARGETS}
input_timeout=${DYNASLICE_FUZZ_INPUT_TIMEOUT:-10}
case "$secs$jobs$input_timeout" in *[!0-9]*) fail "the DYNASLICE_FUZZ_* settings must be whole numbers" ;; esac
[ "$jobs" -ge 1 ] || fail "DYNASLICE_FUZZ_JOBS must be at least 1"

# ---------------------------------------------------------------------------------------------
step "toolchain"
if ! rustup run nightly rustc --version >/dev/null 2>&1; then
    rustup toolchain install nightly --profile minimal ||
        fail "no nightly toolchain, and rustup could not install one (cargo-fuzz needs it)"
fi
rustup run nightly rustc --version
if ! cargo fuzz --version >/dev/null 2>&1; then
    cargo install cargo-fuzz --locked || fail "cargo-fuzz could not be installed"
fi
cargo fuzz --version

# ---------------------------------------------------------------------------------------------
step "build every target (AddressSanitizer, debug assertions)"
build_start=$(date +%s)
sanitizer=address
if ! (cd fuzz && cargo +nightly fuzz build -s address); then
    # Only a sanitizer problem if the same code builds without one; a compile error fails.
    (cd fuzz && cargo +nightly fuzz build -s none) ||
        fail "the fuzz targets do not build (see above)"
    sanitizer=none
    note "AddressSanitizer could not build: fuzzing without a sanitizer (debug assertions and" \
        "overflow checks still on; out-of-bounds reads in unsafe code go unnoticed)"
fi
echo "build: $(($(date +%s) - build_start))s, sanitizer $sanitizer"

# ---------------------------------------------------------------------------------------------
step "fuzz: ${secs}s per target, $jobs at a time"
mkdir -p fuzz/target/ci-fuzz
logs=fuzz/target/ci-fuzz
# Scratch files of the path-taking readers (one folder per process), removed afterwards.
export TMPDIR="$PWD/fuzz/target/ci-fuzz/tmp"
rm -rf "$TMPDIR"
mkdir -p "$TMPDIR"
# Sequence::new validates frames with rayon: one thread keeps parallel jobs from competing.
export RAYON_NUM_THREADS=1

# Reproducers newer than this are this run's.
touch "$logs/stamp"

# Runs one target; its exit status and wall time go to $logs/TARGET.rc and .secs.
run_target() {
    local target=$1 t0 rc corpus="$PWD/fuzz/corpus/$1"
    t0=$(date +%s)
    mkdir -p "$corpus"
    if [ "$secs" -eq 0 ]; then
        set -- -runs=0
    else
        set -- -max_total_time="$secs"
    fi
    set +e
    (cd fuzz && DYNASLICE_FUZZ_SEEDS="$corpus" cargo +nightly fuzz run -s "$sanitizer" \
        "$target" "$corpus" -- "$@" -timeout="$input_timeout" -rss_limit_mb=2048 \
        -print_final_stats=1) >"$logs/$target.log" 2>&1
    rc=$?
    set -e
    echo "$rc" >"$logs/$target.rc"
    echo "$(($(date +%s) - t0))" >"$logs/$target.secs"
}

running=0
for target in $targets; do
    case " $ALL_TARGETS " in *" $target "*) ;; *) fail "no fuzz target $target" ;; esac
    rm -f "$logs/$target.rc"
    run_target "$target" &
    running=$((running + 1))
    if [ "$running" -ge "$jobs" ]; then
        wait -n || true
        running=$((running - 1))
    fi
done
wait || true
rm -rf "$TMPDIR"

# ---------------------------------------------------------------------------------------------
step "results"
final_stat() { sed -n "s/^stat::$2: *//p" "$logs/$1.log" | tail -n 1; }
printf '%-16s %6s %12s %10s %8s %7s  %s\n' target secs executions exec/s edges corpus result
failed=""
for target in $targets; do
    rc=$(cat "$logs/$target.rc" 2>/dev/null || echo "?")
    runs=$(final_stat "$target" number_of_executed_units)
    t=$(cat "$logs/$target.secs" 2>/dev/null || echo "?")
    rate=$(final_stat "$target" average_exec_per_sec)
    # The last status line's coverage and corpus size ("cov: N ft: M corp: C/S"); none where
    # the target never started (`|| true`: under pipefail a grep without a match would end the
    # script here, before the table and the failure report).
    cov=$(grep -Eo 'cov: [0-9]+' "$logs/$target.log" | tail -n 1 | cut -d' ' -f2 || true)
    corp=$(grep -Eo 'corp: [0-9]+' "$logs/$target.log" | tail -n 1 | cut -d' ' -f2 || true)
    result=ok
    [ "$rc" = 0 ] || { result="FAILED (exit $rc)"; failed="$failed $target"; }
    printf '%-16s %6s %12s %10s %8s %7s  %s\n' "$target" "$t" "${runs:-?}" "${rate:-?}" \
        "${cov:-?}" "${corp:-?}" "$result"
done
for target in $failed; do
    echo
    echo "--- $target: last lines of $logs/$target.log"
    grep -v '^#[0-9]' "$logs/$target.log" | tail -n 40
    find "fuzz/artifacts/$target" -type f -newer "$logs/stamp" 2>/dev/null | sed 's/^/reproducer: /'
done
step "done"
[ -z "$failed" ] || fail "fuzz targets failed:$failed (reproducers under fuzz/artifacts/)"
