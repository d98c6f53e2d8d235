#!/usr/bin/env bash
# CI for the Python package, on a fresh machine with Rust and Python 3.9+: a venv, the package
# built and installed as a user would (`pip install ./dynaslice-python`, maturin's release
# build), then pytest, the cohort example's test on a local Ray instance included.
#
# Run from anywhere; the lead's .ci/run calls it after `cargo test --workspace`, which leaves
# target/debug/dynaslice and libdynaslice for the tests that compare against the command line
# and the C ABI (they skip with a message when those are not built).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
venv="${DYNASLICE_VENV:-$here/.venv}"
start=$(date +%s)
step() { echo; echo "=== python: $* ($(( $(date +%s) - start ))s)"; }

step "format and lints of the extension crate"
cargo fmt --manifest-path "$here/Cargo.toml" --check
# The extension is outside the workspace, so the workspace's clippy step does not lint it.
cargo clippy --manifest-path "$here/Cargo.toml" --all-targets -- -D warnings

step "venv $venv"
python3 -m venv "$venv"
py="$venv/bin/python"
"$py" -m pip install --quiet --disable-pip-version-check --upgrade pip
"$py" -m pip install --quiet --disable-pip-version-check maturin pytest numpy nibabel trimesh pyvista

step "pip install ./dynaslice-python (release build)"
t0=$(date +%s)
(cd "$root" && "$py" -m pip install --disable-pip-version-check ./dynaslice-python)
echo "pip install took $(( $(date +%s) - t0 )) s"

step "ray (for the cohort example)"
if "$py" -m pip install --quiet --disable-pip-version-check ray; then
    export DYNASLICE_REQUIRE_RAY=1
else
    echo "ray could not be pip-installed: the cohort example's test will skip"
fi

step "pytest"
# The tests import the installed package, never the source folder.
cd "$here/tests"
set +e
"$py" -m pytest -q -rs .
rc=$?
set -e
if [ "$rc" -eq 5 ]; then
    echo "pytest collected no tests: that is a failure here"
    exit 1
fi
exit "$rc"
