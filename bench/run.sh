#!/usr/bin/env bash
# Regenerates the tables in bench/RESULTS.md (run from the repository root; needs
# ../shared/assets for the bunny and the large meshes).
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release
./target/release/pathlight bench --spp 16 cornell-box bunny-in-cornell
./target/release/pathlight bench --prep-only \
    ../shared/assets/khronos/MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb \
    ../shared/assets/khronos/TransmissionTest/TransmissionTest.glb \
    ../shared/assets/khronos/ToyCar/ToyCar.gltf \
    ../shared/assets/bvh/stanford-bunny.glb
