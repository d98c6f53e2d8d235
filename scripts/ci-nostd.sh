#!/usr/bin/env bash
# Proves that dynaslice-core fits scanner firmware (docs/firmware.md):
#   (a) its direct normal dependencies are exactly bytemuck, half and libm;
#   (b) it builds for a bare-metal Cortex-M4F target (thumbv7em-none-eabihf);
#   (c) ALWAYS: as a #![no_std], panic = "abort" static library it links into a C program built
#       with `gcc -ffreestanding -nostdlib -static` (its own _start, raw syscalls), and there
#       reproduces bit for bit the values the std build computes on the host;
#   (d) an example firmware runs on QEMU's Cortex-M4F board (mps2-an386), reproduces the host's
#       values bit for bit, and reports the stack each query needs and the flash the core takes;
#   (e) if cargo-fuzz and a nightly toolchain are present: a short smoke run of both fuzz targets.
#
# Runs on a fresh Debian machine as root with nothing installed by hand: it installs what it
# needs (rustup target, qemu-system-arm). A part whose prerequisite cannot be fetched is skipped
# with a plain NOTE saying so; (a) and (c) never are. Exits non-zero on any failure.
#
# Environment: DYNASLICE_FUZZ_SECONDS (default 10) per fuzz target, 0 to skip (e).
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TERM_COLOR=never

start=$(date +%s)
step() { echo; echo "=== ci-nostd: $* ($(($(date +%s) - start))s)"; }
fail() { echo "ci-nostd: FAIL: $*" >&2; exit 1; }
note() { echo "ci-nostd: NOTE: $*"; }

GEN="$PWD/firmware/generated"
THUMB=thumbv7em-none-eabihf

# Installs Debian packages when missing; returns non-zero (without failing the script) when
# they cannot be installed, so the caller can say so and skip only its own part.
apt_install() {
    local sudo=""
    if [ "$(id -u)" -ne 0 ]; then
        command -v sudo >/dev/null 2>&1 || return 1
        sudo="sudo -n"
    fi
    export DEBIAN_FRONTEND=noninteractive
    $sudo apt-get update -qq >/dev/null 2>&1 || true
    $sudo apt-get install -y -qq --no-install-recommends "$@" >/dev/null 2>&1
}

# ---------------------------------------------------------------------------------------------
step "(a) direct normal dependencies of dynaslice-core"
tree=$(cargo tree -p dynaslice-core -e normal --depth 1)
echo "$tree"
# Every line but the first is a direct dependency: strip the tree drawing, keep the name.
deps=$(echo "$tree" | tail -n +2 | sed 's/^[^a-zA-Z0-9_-]*//' | awk '{print $1}' | sort | xargs)
[ "$deps" = "bytemuck half libm" ] ||
    fail "dynaslice-core must depend on exactly bytemuck, half and libm; found: $deps"
echo "ok: exactly bytemuck, half, libm"

# ---------------------------------------------------------------------------------------------
step "(b) dynaslice-core for $THUMB"
have_thumb=0
if rustup target list --installed 2>/dev/null | grep -qx "$THUMB" || rustup target add "$THUMB"; then
    have_thumb=1
    cargo build -p dynaslice-core --target "$THUMB" --release
else
    note "the $THUMB target could not be fetched with rustup: skipping (b) and (d)"
fi

# ---------------------------------------------------------------------------------------------
step "(c) freestanding link test (no libc, no Rust std)"
command -v gcc >/dev/null 2>&1 || apt_install gcc || fail "gcc is needed and could not be installed"
# The models to embed and the host (std build) reference transcript.
cargo run --release --locked -q --manifest-path firmware/modelgen/Cargo.toml -- "$GEN"
cargo build --release --locked --manifest-path firmware/freestanding/Cargo.toml
fs=firmware/freestanding
# -fno-builtin / -fno-tree-loop-distribute-patterns: main.c defines memcpy & co. as plain
# loops, which GCC must not turn back into calls to themselves. --gc-sections drops the
# unreachable unwinding glue of core's precompiled objects (and with it the reference to
# rust_eh_personality, which a panic = "abort" program has no definition for).
gcc -O2 -std=c11 -Wall -Wextra -Werror -ffreestanding -nostdlib -static \
    -fno-builtin -fno-tree-loop-distribute-patterns -fno-stack-protector \
    -I "$GEN" -o "$fs/target/selftest" "$fs/main.c" \
    "$fs/target/release/libdynaslice_freestanding.a" -Wl,--gc-sections
file "$fs/target/selftest" 2>/dev/null || true
"$fs/target/selftest" || fail "the freestanding program disagrees with the host (exit $?)"
# Negative control: with one bit of the reference flipped, the same program must fail.
set +e
"$fs/target/selftest" control
rc=$?
set -e
[ "$rc" -eq 1 ] || fail "negative control exited $rc, expected 1: the comparison cannot fail"
echo "ok: bit-exact on the freestanding build; negative control fails as it must"

# ---------------------------------------------------------------------------------------------
step "(d) Cortex-M4F firmware on QEMU mps2-an386"
if [ "$have_thumb" -eq 1 ]; then
    if ! command -v qemu-system-arm >/dev/null 2>&1; then
        apt_install qemu-system-arm ||
            note "qemu-system-arm could not be installed with apt-get: the firmware is built but not run"
    fi
    elf=target/$THUMB/release/dynaslice-cortex-m4
    (cd firmware/cortex-m4 && cargo build --release --locked --features baseline)
    cp "firmware/cortex-m4/$elf" "firmware/cortex-m4/target/baseline.elf"
    (cd firmware/cortex-m4 && cargo build --release --locked)
    if command -v qemu-system-arm >/dev/null 2>&1; then
        out=firmware/cortex-m4/target/qemu.out
        timeout 120 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
            -monitor none -serial none -semihosting-config enable=on,target=native \
            -kernel "firmware/cortex-m4/$elf" >"$out" ||
            { cat "$out"; fail "the firmware failed on QEMU (exit $?)"; }
        grep -v '^T ' "$out"
        grep '^T ' "$out" | cut -d' ' -f2 >firmware/cortex-m4/target/transcript.txt
        [ -s firmware/cortex-m4/target/transcript.txt ] || fail "the firmware printed no transcript"
        diff -q "$GEN/expected.txt" firmware/cortex-m4/target/transcript.txt ||
            fail "the Cortex-M4F values differ from the host's"
        echo "ok: $(wc -l <"$GEN/expected.txt") words bit-exact on the Cortex-M4F"
    fi
    # Flash taken by the core, by difference with the same image built without it.
    section() {
        local hex
        hex=$(readelf -SW "$1" | sed 's/^ *\[ *[0-9]*\] *//' | awk -v s="$2" '$1 == s { print $5 }')
        [ -n "$hex" ] || fail "no section $2 in $1"
        printf '%d' "0x$hex"
    }
    full=firmware/cortex-m4/$elf
    base=firmware/cortex-m4/target/baseline.elf
    models=$(($(stat -c %s "$GEN/model_f32.dsm") + $(stat -c %s "$GEN/model_f16.dsm") +
        $(stat -c %s "$GEN/model_motion.dsm")))
    text=$(($(section "$full" .text) - $(section "$base" .text)))
    rodata=$(($(section "$full" .rodata) - $(section "$base" .rodata) - models))
    core_fns=$(readelf -sW --demangle "$full" |
        awk '$4 == "FUNC" && /dynaslice_core::/ { s += $3 } END { print s + 0 }')
    echo "size: .text +$text bytes, .rodata +$rodata bytes (besides $models bytes of models)" \
        "over the baseline image; functions named dynaslice_core::*: $core_fns bytes"
    echo "size: .bss $(section "$full" .bss) bytes (the batch Scratch and the rig's buffers)"
fi

# ---------------------------------------------------------------------------------------------
step "(e) fuzz smoke run"
secs=${DYNASLICE_FUZZ_SECONDS:-10}
if [ "$secs" -eq 0 ]; then
    note "DYNASLICE_FUZZ_SECONDS=0: fuzzing skipped"
elif ! command -v cargo-fuzz >/dev/null 2>&1 || ! rustup run nightly rustc --version >/dev/null 2>&1; then
    note "cargo-fuzz or a nightly toolchain is missing: fuzzing skipped (see docs/firmware.md)"
else
    cargo run --release --locked -q --manifest-path fuzz/Cargo.toml --example seed_corpus -- fuzz/corpus
    for target in from_bytes_crc from_bytes; do
        log=fuzz/target/smoke-$target.log
        mkdir -p fuzz/target
        set +e
        (cd fuzz && cargo +nightly fuzz run "$target" "corpus/$target" -- \
            -max_total_time="$secs" -print_final_stats=1) >"$log" 2>&1
        rc=$?
        set -e
        grep -E 'stat::number_of_executed_units|stat::peak_rss|Done [0-9]+ runs' "$log" || true
        if [ "$rc" -ne 0 ]; then
            tail -n 60 "$log"
            fail "fuzz target $target failed (exit $rc); reproducer under fuzz/artifacts/$target/"
        fi
    done
fi

step "done: all no_std checks passed"
