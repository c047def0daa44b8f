#!/usr/bin/env bash
# The whole test suite: Rust tests (GPU tests on lavapipe when present), the reference
# tests against libigl and manifold3d (pytest), then the Python package: built, installed
# into .venv, its pytest suite and examples/python.
# Sets up a Python virtual environment in .venv on first use (needs python3 with venv).
#
#   bash tools/test.sh
set -euo pipefail
cd "$(dirname "$0")/.."
# Mesa's software Vulkan (lavapipe) warns on every device when this is unset; harmless.
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo test --workspace
cargo build --bin isokit
# The modeling scripts in examples/ run too (they check their own results).
examples_out=$(mktemp -d)
trap 'rm -rf "$examples_out"' EXIT
cargo run --quiet --example model_in_code -- "$examples_out"
cargo run --quiet --example csg_scene -- "$examples_out/part.obj"
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r tests/reference/requirements.txt
ISOKIT_BIN="${CARGO_TARGET_DIR:-$PWD/target}/debug/isokit" .venv/bin/python -m pytest -q tests/reference
# The Python package: the wheel built from the checkout by the README's one command (a
# release build in this target directory: incremental after the first) and installed into
# .venv, then its tests and the Python modeling script.
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r crates/isokit-python/tests/requirements.txt
.venv/bin/python -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps ./crates/isokit-python
ISOKIT_BIN="${CARGO_TARGET_DIR:-$PWD/target}/debug/isokit" .venv/bin/python -m pytest -q crates/isokit-python/tests
.venv/bin/python examples/python/part.py "$examples_out/python"
.venv/bin/python examples/python/flange.py "$examples_out/python"
