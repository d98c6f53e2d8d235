#!/bin/sh
# Installs the DynaSlice C library for C/C++ hosts (docs/c-api.md, "Install"):
#
#   cargo build --release -p dynaslice-ffi
#   sh dynaslice-ffi/install.sh PREFIX [LIBDIR]
#
# LIBDIR is where cargo put libdynaslice.{so,a} (default: target/release of this workspace).
# Installs PREFIX/include/dynaslice{,_vtk}.h, PREFIX/lib/libdynaslice.{so,a},
# PREFIX/lib/pkgconfig/dynaslice.pc and PREFIX/lib/cmake/dynaslice/ (find_package(dynaslice)).
# The pkg-config and CMake files locate the prefix relative to themselves, so the tree can be
# moved or packaged as it is.
set -eu

if [ $# -lt 1 ] || [ $# -gt 2 ]; then
    echo "usage: $0 PREFIX [LIBDIR]" >&2
    exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
prefix=$1
libdir=${2:-$root/target/release}

for lib in libdynaslice.so libdynaslice.a; do
    if [ ! -f "$libdir/$lib" ]; then
        echo "$libdir/$lib not found: run 'cargo build --release -p dynaslice-ffi' first" >&2
        exit 1
    fi
done
# The workspace version, from the root manifest's [workspace.package].
version=$(sed -n 's/^version = "\(.*\)"$/\1/p' "$root/Cargo.toml" | head -n 1)
# What `rustc --print native-static-libs` reports for the static library on Linux (less -lc and
# -lgcc_s, which every C link adds itself).
static_libs="-lutil -lrt -lpthread -lm -ldl"

mkdir -p "$prefix/include" "$prefix/lib/pkgconfig" "$prefix/lib/cmake/dynaslice"
cp "$root/include/dynaslice.h" "$root/include/dynaslice_vtk.h" "$prefix/include/"
cp "$libdir/libdynaslice.so" "$libdir/libdynaslice.a" "$prefix/lib/"
fill() {
    sed -e "s|@VERSION@|$version|g" -e "s|@STATIC_LIBS@|$static_libs|g" "$1" > "$2"
}
fill "$here/pkg/dynaslice.pc.in" "$prefix/lib/pkgconfig/dynaslice.pc"
fill "$here/pkg/dynasliceConfig.cmake.in" "$prefix/lib/cmake/dynaslice/dynasliceConfig.cmake"
fill "$here/pkg/dynasliceConfigVersion.cmake.in" \
    "$prefix/lib/cmake/dynaslice/dynasliceConfigVersion.cmake"
echo "installed dynaslice $version into $prefix"
