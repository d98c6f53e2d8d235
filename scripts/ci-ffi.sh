#!/usr/bin/env bash
# CI for the C ABI (dynaslice-ffi): run from anywhere as `bash scripts/ci-ffi.sh`.
#
# 1. Installs what it needs on a fresh Debian machine (as root): gcc/g++ (with libasan/libubsan),
#    valgrind, python3, pkg-config, cmake, libvtk9-dev (~175 MB download), and cbindgen at the
#    pinned version.
# 2. Fails when include/dynaslice.h differs from a fresh cbindgen generation.
# 3. Runs the host tests (C static/shared, valgrind, the C host built with ASan + LeakSanitizer +
#    UBSan against the cdylib, C++ threads, docs example, CMake and pkg-config install, Python),
#    with every host tool present, so none of them may skip.
# 4. Installs the release build into a temporary prefix, builds the VTK example against it with
#    find_package(dynaslice), extracts both surfaces of the sphere fixture and checks each mesh:
#    closed, vertices on f = 0, gradients right, enclosed volume within 2% of the project's own
#    mesh (`dynaslice mesh`), which itself must be within 1% of the model's interior counted on
#    a 256³ grid.
# 5. The time rule through VTK: the adapter's test (dynaslice-ffi/tests/vtk) answers both edges of
#    the time range and reports a time outside it once through vtkErrorMacro with NaN values; the
#    example refuses such a time before sampling, writing nothing.
set -euo pipefail

CBINDGEN_VERSION=0.29.4
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
step() { printf '\n== %s (%ds)\n' "$*" "$SECONDS"; }

step "system packages"
need=()
for pair in gcc:gcc g++:g++ valgrind:valgrind python3:python3 pkg-config:pkg-config cmake:cmake; do
    command -v "${pair%%:*}" >/dev/null || need+=("${pair#*:}")
done
dpkg -s libvtk9-dev >/dev/null 2>&1 || need+=(libvtk9-dev)
if [ ${#need[@]} -gt 0 ]; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends "${need[@]}" >"$work/apt.log" 2>&1 ||
        { tail -n 30 "$work/apt.log"; exit 1; }
    echo "installed: ${need[*]}"
fi
# The sanitizer run (hosts.rs `c_host_under_sanitizers`) needs gcc's libasan and libubsan; Debian
# ships them in libgcc-N-dev, which gcc depends on, so this only installs on an image that lacks them.
echo 'int main(void) { return 0; }' >"$work/sanitizers.c"
if ! gcc -fsanitize=address,undefined "$work/sanitizers.c" -o "$work/sanitizers" 2>/dev/null; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends "libgcc-$(gcc -dumpversion)-dev" >"$work/apt.log" 2>&1 ||
        { tail -n 30 "$work/apt.log"; exit 1; }
    echo "installed: libgcc-$(gcc -dumpversion)-dev (libasan, libubsan)"
fi

step "cbindgen $CBINDGEN_VERSION"
if ! cbindgen --version 2>/dev/null | grep -qx "cbindgen $CBINDGEN_VERSION"; then
    cargo install cbindgen --version "$CBINDGEN_VERSION" --locked
fi

step "header is up to date"
cbindgen --quiet --config dynaslice-ffi/cbindgen.toml --crate dynaslice-ffi --output "$work/dynaslice.h"
if ! diff -u include/dynaslice.h "$work/dynaslice.h"; then
    echo "include/dynaslice.h is stale: regenerate it with" >&2
    echo "  cbindgen --config dynaslice-ffi/cbindgen.toml --crate dynaslice-ffi --output include/dynaslice.h" >&2
    exit 1
fi

step "format and lints"
cargo fmt -p dynaslice-ffi -- --check
cargo clippy -p dynaslice-ffi --all-targets -- -D warnings

step "host tests"
# Every tool was installed above: a host test that would skip fails instead.
DYNASLICE_REQUIRE_HOSTS=1 cargo test -p dynaslice-ffi

step "release build and install"
cargo build --release -p dynaslice-ffi --lib --example sphere_fixture
# The project's own mesher, the reference for the VTK surface. Built with the test profile, so
# it reuses what `cargo test --workspace` compiled instead of a second copy of every dependency.
cargo build --profile test -p dynaslice-cli --bin dynaslice
dynaslice=target/debug/dynaslice
sh dynaslice-ffi/install.sh "$work/prefix" target/release

step "VTK example"
cmake -S examples/vtk -B "$work/vtk" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_PREFIX_PATH="$work/prefix" >"$work/cmake.log" || { cat "$work/cmake.log"; exit 1; }
cmake --build "$work/vtk" -- -j2
fixture=target/release/examples/sphere_fixture
"$fixture" write "$work/spheres.dsm"
# (class, time): the breathing sphere at two phases, and the small one.
for case in "1 0" "1 0.25" "2 0.5"; do
    set -- $case
    "$work/vtk/dynaslice_surface" "$work/spheres.dsm" "$1" "$2" 96 "$work/class$1.vtp" | tee "$work/vtk.out"
    "$dynaslice" mesh "$work/spheres.dsm" --time "$2" --class "$1" --resolution 128 \
        -o "$work/own$1_$2.ply" >"$work/own.out" 2>&1 || { cat "$work/own.out"; exit 1; }
    counted=$("$fixture" volume "$work/spheres.dsm" "$1" "$2" 256)
    python3 - "$work/vtk.out" "$work/own.out" "$counted" "$work/class$1.vtp" <<'PY'
import os, re, sys
out = dict(line.rsplit(" ", 1) for line in open(sys.argv[1]).read().splitlines())
own = re.findall(r"volume ([0-9.eE+-]+),", open(sys.argv[2]).read())
assert len(own) == 1, "dynaslice mesh reported no single volume"
volume, reference, counted = float(out["volume"]), float(own[0]), float(sys.argv[3])
error = abs(volume - reference) / reference
print(f"VTK volume {volume:.1f}, dynaslice mesh volume {reference:.1f}: {100 * error:.2f}% apart")
assert error < 0.02, "enclosed volumes differ by more than 2%"
# The project's mesh against the model's own interior counted on a 256³ grid.
assert abs(reference - counted) < 0.01 * counted, f"dynaslice mesh {reference} vs counted {counted}"
assert int(out["open edges"]) == 0, "the surface is not closed"
# Vertices interpolate f = 0 between samples 1.04 mm apart: well under a sample spacing.
assert float(out["max |f| at vertices"]) < 0.1, "mesh vertices are off the surface"
assert float(out["max gradient gap"]) < 0.05, "EvaluateGradient disagrees with differences"
assert os.path.getsize(sys.argv[4]) > 10000, "the .vtp is suspiciously small"
PY
done

step "VTK adapter: the time rule"
cmake -S dynaslice-ffi/tests/vtk -B "$work/vtk-test" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_PREFIX_PATH="$work/prefix" >"$work/cmake-test.log" || { cat "$work/cmake-test.log"; exit 1; }
cmake --build "$work/vtk-test" -- -j2
"$work/vtk-test/vtk_time_test" "$work/spheres.dsm"
# The fixture's time range is [0, 1]: 1.5 is refused before sampling, and nothing is written.
if "$work/vtk/dynaslice_surface" "$work/spheres.dsm" 1 1.5 32 "$work/late.vtp" 2>"$work/late.err"; then
    echo "dynaslice_surface accepted t = 1.5, outside the model's time range [0, 1]" >&2
    exit 1
fi
grep -q "t = 1.5 is outside the model's time range \[0, 1\]" "$work/late.err" ||
    { cat "$work/late.err"; exit 1; }
test ! -e "$work/late.vtp"
# The upper edge is answered.
"$work/vtk/dynaslice_surface" "$work/spheres.dsm" 1 1 32 "$work/edge.vtp" >/dev/null

step "ci-ffi passed"
