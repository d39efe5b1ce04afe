#!/usr/bin/env bash
# Measures the farm for bench/RESULTS.md ("One image over many machines"): the same image
# on 1 and 2 local Dask workers of one thread each, a shard's fixed cost, and the merge's
# cost per shard at 4K. Run from anywhere, after `cargo build --release`; needs Python 3
# with dask.distributed.
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
bin=$PWD/target/release/pathlight
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
scene=scenes/cornell-box.gltf
image=(--backend cpu --width 256 --height 256 --seed 0)
echo "## The same image (cornell-box, 256², 128 spp, CPU) in 8 shards"
for workers in 1 2; do
    RAYON_NUM_THREADS=1 python3 farm/pathlight_farm.py "$scene" -o "$work/w$workers.exr" --spp 128 --shards 8 \
        --workers "$workers" --work-dir "$work/shards$workers" -- "${image[@]}" 2>/dev/null
done
echo "one process, one thread:"
RAYON_NUM_THREADS=1 $bin render "$scene" --spp 128 "${image[@]}" -o "$work/one.exr" 2>&1 | tail -n 1
echo
echo "## A shard's fixed cost: one sample of a 64×64 image, whole process"
for backend in cpu gpu; do
    /usr/bin/time -f "$backend: %e s wall" $bin render "$scene" --spp 1 --shard 0/1 --backend "$backend" \
        --width 64 --height 64 -o "$work/tiny-$backend.exr" 2>&1 | tail -n 1
done
echo
echo "## Merging 4 shards of a 3840×2160 image (1 sample each, emitters only)"
for i in 0 1 2 3; do
    $bin render "$scene" --spp 4 --shard "$i/4" --backend cpu --width 3840 --height 2160 --splits 1 \
        --max-depth 0 -o "$work/4k-$i.exr" 2>/dev/null
done
ls -l "$work"/4k-0.exr | awk '{printf "a 4K part: %.0f MB\n", $5 / 1e6}'
/usr/bin/time -f "merge of 4 parts: %e s wall, %M KB peak" $bin merge "$work"/4k-*.exr -o "$work/4k.exr" 2>&1 | tail -n 1
