#!/usr/bin/env bash
# Renders every Khronos sample model in ../shared/assets/khronos under an HDR environment to
# PNG (out/gallery/), prints each model's render time, and tiles the renders into
# docs/gallery.png (the README's contact sheet). Run from anywhere; needs ../shared/assets.
#   scenes/gallery.sh [--backend cpu|gpu] [--spp N] [--size PX]
set -euo pipefail
cd "$(dirname "$0")/.."
backend=cpu spp=64 size=200
while [ $# -gt 0 ]; do
    case "$1" in
        --backend) backend=$2; shift 2 ;;
        --spp) spp=$2; shift 2 ;;
        --size) size=$2; shift 2 ;;
        *) echo "usage: $0 [--backend cpu|gpu] [--spp N] [--size PX]" >&2; exit 2 ;;
    esac
done
assets=../shared/assets
[ -d "$assets/khronos" ] || { echo "gallery.sh: $assets/khronos not found" >&2; exit 1; }
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release --quiet --bin pathlight --example contact_sheet
mkdir -p out/gallery docs
renders=()
printf '| model | triangles | seconds (%s, %d spp, %d²) |\n|---|---:|---:|\n' "$backend" "$spp" "$size"
for dir in "$assets"/khronos/*/; do
    model=$(ls "$dir" | grep -E '\.(glb|gltf)$' | head -n 1)
    name=${model%.*}
    out=out/gallery/$name.png
    log=$(./target/release/pathlight render "$dir$model" --backend "$backend" --spp "$spp" \
        --width "$size" --height "$size" --env "$assets/env/studio_small_05_1k.hdr" --env-intensity 3 \
        --tonemap aces -o "$out" 2>&1) || { echo "$log" >&2; exit 1; }
    tris=$(echo "$log" | grep -oE '[0-9]+ triangles' | head -n 1 | cut -d' ' -f1)
    secs=$(echo "$log" | grep -oE 'in [0-9.]+ s:' | tail -n 1 | grep -oE '[0-9.]+')
    printf '| %s | %s | %s |\n' "$name" "$tris" "$secs"
    renders+=("$out")
done
./target/release/examples/contact_sheet docs/gallery.png 6 "${renders[@]}"
echo "wrote docs/gallery.png (${#renders[@]} models)"
