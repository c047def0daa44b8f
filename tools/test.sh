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
# The viewer's window tests need an X server: without one, a virtual one (Xvfb) when it is
# installed (otherwise they skip with a note, or fail under ISOKIT_REQUIRE_DISPLAY=1).
xvfb_pid=""
if [ -z "${DISPLAY:-}" ] && command -v Xvfb >/dev/null; then
  for n in $(seq 90 120); do
    [ -e "/tmp/.X11-unix/X$n" ] || [ -e "/tmp/.X$n-lock" ] || break
  done
  Xvfb ":$n" -screen 0 1024x768x24 -nolisten tcp >/dev/null 2>&1 &
  xvfb_pid=$!
  trap 'kill "$xvfb_pid" 2>/dev/null || true' EXIT
  export DISPLAY=":$n"
  for _ in $(seq 50); do [ -e "/tmp/.X11-unix/X$n" ] && break; sleep 0.1; done
fi
cargo test --workspace
# `cargo test --workspace` has built the binary (target/debug/isokit) and the examples
# (target/debug/examples) with the features of the whole workspace, dev-dependencies
# included. They are run from there: `cargo build --bin isokit` or `cargo run --example`
# would resolve features for one package alone (other features of bytemuck, serde, num, …)
# and compile about 70 crates a second time (4–5 minutes on 2 cores).
# The target directory as cargo resolves it (CARGO_TARGET_DIR, CARGO_BUILD_TARGET_DIR or a
# config's build.target-dir), so these are the files `cargo test` has just written.
target_dir=$(cargo metadata --no-deps --format-version 1 |
  python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')
bin_dir="$target_dir/debug"
# The modeling scripts in examples/ run too (they check their own results).
examples_out=$(mktemp -d)
trap 'rm -rf "$examples_out"; [ -z "$xvfb_pid" ] || kill "$xvfb_pid" 2>/dev/null || true' EXIT
"$bin_dir/examples/model_in_code" "$examples_out"
"$bin_dir/examples/csg_scene" "$examples_out/part.obj"
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r tests/reference/requirements.txt
ISOKIT_BIN="$bin_dir/isokit" .venv/bin/python -m pytest -q tests/reference
# The Python package: the wheel built from the checkout by the README's one command and
# installed into .venv, then its tests and the Python modeling script. Built in the dev
# profile (MATURIN_PEP517_ARGS; the same settings as the test profile, so the workspace's
# crates `cargo test` compiled above are reused and only the extension is compiled: a
# release build would compile every crate again, about 5 minutes on 2 cores). Users' `pip
# install` builds release.
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r crates/isokit-python/tests/requirements.txt
MATURIN_PEP517_ARGS="${MATURIN_PEP517_ARGS:---profile dev}" \
  .venv/bin/python -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps ./crates/isokit-python
ISOKIT_BIN="$bin_dir/isokit" .venv/bin/python -m pytest -q crates/isokit-python/tests
.venv/bin/python examples/python/part.py "$examples_out/python"
.venv/bin/python examples/python/flange.py "$examples_out/python"
