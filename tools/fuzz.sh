#!/usr/bin/env bash
# Fuzzing isokit's readers with AFL++ through cargo-afl (stable toolchain).
#
#   bash tools/fuzz.sh build                 # cargo-afl (installed if missing), AFL++, the harness
#   bash tools/fuzz.sh run SECONDS [TARGET…] # each target (default: all) for SECONDS, from its
#                                            # corpus; findings in fuzz/out/TARGET, a table of
#                                            # executions, crashes and hangs; exit 1 on a crash
#   bash tools/fuzz.sh targets               # the target names
#
# CI runs `build` and `run 3`. A long local campaign: `bash tools/fuzz.sh run 3600`, or one
# target in the background: `bash tools/fuzz.sh run 86400 obj &`. A crash is reproduced
# with `fuzz/target/debug/isokit-fuzz-afl TARGET FILE` (after `cargo build` in fuzz/), then
# copied to fuzz/corpus/TARGET/crash-NAME with a regression test beside the fix.
# With a nightly toolchain, cargo-fuzz runs the same targets:
#   cd fuzz && cargo +nightly fuzz run obj corpus/obj -- -max_total_time=600
set -euo pipefail
cd "$(dirname "$0")/.."
targets=(obj ply stl off gltf glb xyz nrrd npy nifti nifti_gz inr vtk vtu pdb mmcif molecule_gz scene_json scene_toml)
export CARGO_TARGET_DIR="${FUZZ_TARGET_DIR:-$PWD/fuzz/target}"
bin="$CARGO_TARGET_DIR/release/isokit-fuzz-afl"

case "${1:-}" in
build)
  command -v cargo-afl >/dev/null 2>&1 || cargo install cargo-afl --locked --version 0.18.2
  # Builds AFL++ from the sources the afl crate ships (once per machine; C only).
  if ! out=$(cargo afl config --build 2>&1) && ! grep -q "already built" <<<"$out"; then
    echo "$out" >&2
    exit 1
  fi
  (cd fuzz && cargo afl build --release --locked -p isokit-fuzz-afl)
  ;;
run)
  seconds="${2:?seconds per target}"
  shift 2
  [ $# -gt 0 ] && targets=("$@")
  [ -x "$bin" ] || { echo "build first: bash tools/fuzz.sh build" >&2; exit 2; }
  # Two shared cores, no core dumps configured, no UI.
  export AFL_SKIP_CPUFREQ=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1 AFL_NO_UI=1 \
    AFL_NO_AFFINITY=1 AFL_SKIP_CRASHES=1 AFL_FAST_CAL=1 AFL_QUIET=1
  printf '%-12s %12s %8s %8s %8s\n' target executions exec/s crashes hangs
  crashed=0
  for t in "${targets[@]}"; do
    out="fuzz/out/$t"
    rm -rf "$out"
    mkdir -p "$out"
    timeout -k 10 $((seconds + 60)) cargo afl fuzz -i "fuzz/corpus/$t" -o "$out" \
      -V "$seconds" -t 2000 -m none -- "$bin" "$t" >"$out/log" 2>&1 || true
    stats="$out/default/fuzzer_stats"
    get() { awk -F: -v k="$1" '$1 ~ "^"k" *$" {gsub(/ /, "", $2); print $2}' "$stats" 2>/dev/null; }
    crashes=$(get saved_crashes); hangs=$(get saved_hangs)
    printf '%-12s %12s %8s %8s %8s\n' "$t" "$(get execs_done)" "$(get execs_per_sec)" \
      "${crashes:-?}" "${hangs:-?}"
    if [ -z "$crashes" ]; then
      echo "  $t: AFL++ did not start; see $out/log:" >&2
      tail -5 "$out/log" >&2
      crashed=1
    elif [ "$crashes" != 0 ]; then
      ls "$out"/default/crashes/id:* >&2
      crashed=1
    fi
  done
  exit "$crashed"
  ;;
targets)
  printf '%s\n' "${targets[@]}"
  ;;
*)
  sed -n '2,17p' "$0" >&2
  exit 2
  ;;
esac
