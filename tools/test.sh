#!/usr/bin/env bash
# The whole test suite: Rust tests, then the reference tests against libigl (pytest).
# Sets up a Python virtual environment in .venv on first use (needs python3 with venv).
#
#   bash tools/test.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace
cargo build --bin isokit
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r tests/reference/requirements.txt
ISOKIT_BIN="$PWD/target/debug/isokit" .venv/bin/python -m pytest -q tests/reference
