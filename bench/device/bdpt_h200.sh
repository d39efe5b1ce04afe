#!/usr/bin/env bash
# BDPT against the path tracer on a lent GPU (issue 43's goals "on the hardware"), run by
# the device tool from the repository root with a stripped release binary at .devbin/pathlight
# and the Vulkan loader's packages in .gl/ (bench/README.md, "On a lent GPU").
# Results go to $OUT/bdpt-h200.tar.gz: the throughput table, both summaries and the series.
set -uo pipefail
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
if [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]; then
    export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
export XDG_RUNTIME_DIR=/tmp
B=./.devbin/pathlight
R=$OUT/bdpt-h200; mkdir -p "$R"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv | tee "$R/gpu.txt"
$B info 2>&1 | tee "$R/info.txt"
# Throughput per integrator (512², 64 timed spp after a warm-up).
timeout 90 $B bench --no-cpu --integrator path,bdpt --spp 64 cornell-box cornell-spheres lamp-shade-room 2>&1 | tee "$R/throughput.md"
# Error against time, 256², 5-second series per integrator, references on the GPU:
# path-traced for the two Cornell boxes, bidirectional for the lamp room (at 128², as on the CPU).
timeout 150 $B bench --peer pbrt --pathlight-only --no-cpu --integrator path,bdpt --width 256 --height 256 \
    --peer-seconds 5 --reference-spp 32768 --out "$R/cornell" cornell-box cornell-spheres 2>&1 | tee "$R/cornell.log"
timeout 150 $B bench --peer pbrt --pathlight-only --no-cpu --integrator path,bdpt --width 128 --height 128 \
    --peer-seconds 5 --reference-spp 32768 --reference-integrator bdpt --out "$R/lamp" lamp-shade-room 2>&1 | tee "$R/lamp.log"
find "$R" -name '*.exr' -delete
tar -C "$OUT" -czf "$OUT/bdpt-h200.tar.gz" bdpt-h200 && rm -rf "$R"
