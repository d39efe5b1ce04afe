#!/usr/bin/env bash
# Denoising and adaptive sampling on a lent GPU (issue 47), run by the device tool from the
# repository root (bench/README.md, "On a lent GPU"): stripped binaries in .devbin/ (pathlight,
# the denoise_error and adaptive_error examples, the `gpu` integration tests, all built
# without the oidn feature), the Vulkan loader in .gl/, and the shared assets it needs copied
# to .devassets/. Writes $OUT/h200-47.tar.gz: converged references for the CPU runs here,
# the GPU's own tables, and the small-image sample check.
set -uo pipefail
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
if [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
export XDG_RUNTIME_DIR=/tmp
B=.devbin/pathlight
R=$OUT/h200-47; mkdir -p "$R/refs"
E=".devassets/studio_small_05_1k.hdr"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$R/gpu.txt"
# Every sample lands however many a dispatch carries (MAX_DISPATCH_SAMPLES).
# (The tests find the repository from where they were built: a link to here stands in.)
mkdir -p /work && ln -sfn "$PWD" /work/main 2>/dev/null
timeout 60 .devbin/gpu_tests every_sample 2>&1 | tail -3 | tee "$R/every_sample.txt"
ref() { # name scene size spp [extra...]
    local name=$1 scene=$2 size=$3 spp=$4; shift 4
    timeout 75 $B render "$scene" --backend gpu --width "$size" --height "$size" --spp "$spp" \
        --seed 1000003 -o "$R/refs/$name-$size-reference.exr" "$@" 2>&1 | tail -1 | tee -a "$R/refs.log"
}
scenes="cornell-spheres:scenes/cornell-spheres.gltf DamagedHelmet:.devassets/DamagedHelmet.glb
        GlassVaseFlowers:.devassets/GlassVaseFlowers.glb ToyCar:.devassets/ToyCar/ToyCar.gltf"
env_for() { [ "$1" = cornell-spheres ] || echo "--env $E --env-intensity 3"; }
# References for this VM's CPU runs (128²), then the 512² denoising scenes.
for m in $scenes; do name=${m%%:*}; ref "$name" "${m#*:}" 128 32768 $(env_for "$name"); done
ref cornell-box scenes/cornell-box.gltf 512 16384
ref DamagedHelmet .devassets/DamagedHelmet.glb 512 8192 --env $E --env-intensity 3
# Denoising on the GPU at 512²: the AOV pass and the à-trous iterations there.
timeout 90 .devbin/denoise_error scenes/cornell-box.gltf --backend gpu --size 512 --spp 4,16,64 \
    --reference "$R/refs/cornell-box-512-reference.exr" --out /tmp/dn 2>&1 | tail -8 | tee "$R/denoise-cornell.md"
timeout 90 .devbin/denoise_error .devassets/DamagedHelmet.glb --backend gpu --size 512 --spp 4,16,64 \
    --env $E --env-intensity 3 --reference "$R/refs/DamagedHelmet-512-reference.exr" --out /tmp/dn 2>&1 | tail -8 | tee "$R/denoise-helmet.md"
# Adaptive against uniform sampling at equal time on the GPU, 256².
for m in $scenes; do
    name=${m%%:*}
    ref "$name" "${m#*:}" 256 16384 $(env_for "$name")
    timeout 60 .devbin/adaptive_error "${m#*:}" --backend gpu --size 256 --spp 2048 \
        --thresholds 0.1,0.05,0.03,0.02 $(env_for "$name") \
        --reference "$R/refs/$name-256-reference.exr" 2>&1 | tail -8 | tee "$R/adaptive-$name.md"
done
tar -C "$OUT" -czf "$OUT/h200-47.tar.gz" h200-47 && rm -rf "$R"
