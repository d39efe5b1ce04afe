#!/usr/bin/env bash
# Regenerates the throughput, scene-preparation and memory tables of bench/RESULTS.md (run
# from anywhere; needs ../shared/assets for the bunny and the large meshes). The gallery's
# times come from scenes/gallery.sh, time to equal error from `pathlight bench --peer`
# (bench/README.md).
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release
bin=./target/release/pathlight
echo "## Throughput"
$bin bench --spp 16 cornell-box bunny-in-cornell cornell-spheres glass-rough env-objects
echo
echo "## Scene preparation"
$bin bench --prep-only cornell-box cornell-spheres bunny-in-cornell \
    ../shared/assets/khronos/MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb \
    ../shared/assets/khronos/TransmissionTest/TransmissionTest.glb \
    ../shared/assets/khronos/ToyCar/ToyCar.gltf \
    ../shared/assets/bvh/stanford-bunny.glb
echo
echo "## Peak resident memory (Cornell box, 256², whole process)"
echo "| backend | spp | peak RSS |"
echo "|---|---:|---:|"
out=$(mktemp -d)
for backend in cpu gpu; do
    for spp in 16 256 1024; do
        kb=$( { /usr/bin/time -f "%M" $bin render scenes/cornell-box.gltf --width 256 --height 256 \
            --spp "$spp" --backend "$backend" -o "$out/memory.exr" >/dev/null 2>/dev/null; } 2>&1 | tail -n 1)
        printf '| %s | %d | %.1f MB |\n' "$backend" "$spp" "$(echo "$kb / 1000" | bc -l)"
    done
done
rm -rf "$out"
