#!/usr/bin/env bash
# GPU and CPU figures in one JSON, for the day a GPU machine is lent (the device tool's
# README says how to bring the Vulkan loader there). It builds the release binary (unless
# ISOKIT points at one), makes its own inputs, and measures:
#
#   raycast  `isokit bench render --json` (warm frames, median; the sphere at res³, the
#            trefoil band, the CT-like density) on the GPU and the CPU twin at 512² and
#            1920x1080 for res 256, and on the GPU the largest field (LARGE_RES, default 512;
#            skipped on a software adapter unless set);
#   splat    `isokit molecule --stats` (spacefill, 1024x768, one process per frame, so the
#            GPU figure includes pipeline creation) on generated lattices of 1k, 10k, 100k
#            and 1M atoms, both backends;
#   prism    `isokit sdf --method prism` (the trefoil's band, 4% of the box, res 256), wall
#            seconds of the whole command, both backends.
#
# Where the only adapter is a software rasterizer (lavapipe, llvmpipe) every GPU figure
# carries "software": true (raycast: the bench's own key; splat and prism: the device
# string), and such figures say nothing about a GPU.
#
# Usage: tools/gpu-figures.sh [OUT.json]   (default gpu-figures.json)
#   ISOKIT=path/to/isokit   use this binary instead of building one
#   QUICK=1                 small sizes (a smoke run of a few minutes on lavapipe)
#   STEP_TIMEOUT=seconds    limit of each measurement (default 150); a step past it is
#                           recorded as {"error": "timeout"} and the run goes on
# Budget on a GPU machine: well under 8 minutes after the build.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-gpu-figures.json}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
quick=${QUICK:-0}
step_timeout=${STEP_TIMEOUT:-150}
started=$(date +%s)

if [[ -z ${ISOKIT:-} ]]; then
    (cd "$root" && cargo build --release --bin isokit >&2)
    ISOKIT=${CARGO_TARGET_DIR:-$root/target}/release/isokit
fi
[[ -x $ISOKIT ]] || { echo "no isokit binary at $ISOKIT" >&2; exit 1; }

if [[ $quick == 1 ]]; then
    res=48 frames=1 sizes=("96 96" "192 108") atoms=(1000 10000) prism_res=64
else
    res=256 frames=3 sizes=("512 512" "1920 1080") atoms=(1000 10000 100000 1000000) prism_res=256
fi

# Runs a measurement under the step timeout; prints its stdout's last line (a JSON value)
# or an error object.
measure() {
    local log=$work/step.log
    if timeout "$step_timeout" "$@" >"$work/step.out" 2>"$log"; then
        tail -n 1 "$work/step.out"
    elif [[ $? == 124 ]]; then
        echo '{"error": "timeout"}'
    else
        printf '{"error": "%s"}' "$(tail -n 1 "$log" | tr -d '"\\' | cut -c1-200)"
    fi
}

# Wall seconds of a command, or an error object.
wall() {
    local t0 t1
    t0=$(date +%s.%N)
    if timeout "$step_timeout" "$@" >"$work/step.out" 2>"$work/step.log"; then
        t1=$(date +%s.%N)
        awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.4f", b - a }'
    else
        printf '{"error": "%s"}' "$(tail -n 1 "$work/step.log" | tr -d '"\\' | cut -c1-200)"
    fi
}

gpu_device=$("$ISOKIT" bench render --json --gpu --size 8 --res 16 --frames 1 2>/dev/null |
    sed -n 's/.*"device":"\([^"]*\)".*/\1/p' || true)
[[ -n $gpu_device ]] || gpu_device=none
software=false
if [[ $gpu_device =~ (llvmpipe|lavapipe|SwiftShader|WARP|Cpu) ]]; then software=true; fi
echo "GPU: $gpu_device (software: $software)" >&2

# 1. The ray caster.
raycast=""
for backend in gpu cpu; do
    flag=""
    [[ $backend == gpu ]] && flag=--gpu
    [[ $backend == gpu && $gpu_device == none ]] && continue
    for s in "${sizes[@]}"; do
        read -r w h <<<"$s"
        echo "raycast $backend ${w}x$h res $res" >&2
        j=$(measure "$ISOKIT" bench render --json $flag --size "$w" --height "$h" --res "$res" --frames "$frames")
        raycast+="${raycast:+,}{\"backend\":\"$backend\",\"width\":$w,\"height\":$h,\"res\":$res,\"bench\":$j}"
    done
done
large_res=${LARGE_RES:-}
if [[ -z $large_res && $software == false && $quick != 1 ]]; then large_res=512; fi
if [[ -n $large_res && $gpu_device != none ]]; then
    echo "raycast gpu 512x512 res $large_res" >&2
    j=$(measure "$ISOKIT" bench render --json --gpu --size 512 --res "$large_res" --frames "$frames")
    raycast+=",{\"backend\":\"gpu\",\"width\":512,\"height\":512,\"res\":$large_res,\"bench\":$j}"
fi

# 2. The splatter on generated molecules: a cubic lattice of carbon atoms 3.2 Å apart.
splat=""
for n in "${atoms[@]}"; do
    pdb=$work/lattice_$n.pdb
    awk -v n="$n" 'BEGIN {
        s = int(exp(log(n) / 3)) + 1; k = 0
        for (i = 0; i < s && k < n; i++) for (j = 0; j < s && k < n; j++) for (l = 0; l < s && k < n; l++) {
            k++
            printf "HETATM%5d  C   UNK A   1    %8.3f%8.3f%8.3f  1.00  0.00           C\n", k % 100000, i * 3.2, j * 3.2, l * 3.2
        }
        print "END"
    }' >"$pdb"
    for backend in gpu cpu; do
        [[ $backend == gpu && $gpu_device == none ]] && continue
        echo "splat $backend $n atoms" >&2
        j=$(measure "$ISOKIT" molecule "$pdb" -o "$work/m.png" --width 1024 --height 768 --style spacefill --backend "$backend" --stats)
        splat+="${splat:+,}{\"backend\":\"$backend\",\"atoms\":$n,\"stats\":$j}"
    done
done

# 3. The prism band of the trefoil mesh.
prism=""
for backend in gpu cpu; do
    [[ $backend == gpu && $gpu_device == none ]] && continue
    echo "prism $backend res $prism_res" >&2
    s=$(wall "$ISOKIT" sdf "$root/data/trefoil.ply" -o "$work/band.nrrd" --method prism --band 0.04 \
        --res "$prism_res" --backend "$backend")
    prism+="${prism:+,}{\"backend\":\"$backend\",\"res\":$prism_res,\"band\":0.04,\"seconds\":$s}"
done

elapsed=$(($(date +%s) - started))
cat >"$out" <<EOF
{"device": "$gpu_device", "software": $software, "quick": $([[ $quick == 1 ]] && echo true || echo false),
 "isokit": "$ISOKIT", "cores": $(nproc), "seconds": $elapsed,
 "raycast": [$raycast],
 "splat": [$splat],
 "prism": [$prism]}
EOF
echo "wrote $out in $elapsed s" >&2
