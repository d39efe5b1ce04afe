#!/usr/bin/env bash
# Instructions per CPU render, counted by valgrind's callgrind: a measure of the CPU backend's
# work that, unlike seconds on a shared VM (±10–15% between runs), does not move with the
# host, so changes of a few percent can be seen. Run from the repository root; needs
# `apt-get install valgrind`. Each count is one thread rendering 96×96 at 8 unsplit spp
# (`--splits 1`, the samples earlier counts were taken with; about 8 M of it is start-up:
# loading, the BVH, writing the EXR).
#
#   bench/instructions.sh [BINARY] [SCENE...]   (default: target/release/pathlight, the
#                                                Cornell box and the mirror-and-glass scene)
set -euo pipefail
cd "$(dirname "$0")/.."
command -v valgrind >/dev/null || { echo "bench/instructions.sh needs valgrind (apt-get install valgrind)" >&2; exit 2; }
binary="${1:-target/release/pathlight}"
shift || true
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(scenes/cornell-box.gltf scenes/cornell-spheres.gltf)
[ -x "$binary" ] || { echo "no binary at $binary (cargo build --release)" >&2; exit 2; }
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
for scene in "${scenes[@]}"; do
    if ! log=$(XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}" RAYON_NUM_THREADS=1 valgrind --tool=callgrind \
        --callgrind-out-file="$out/callgrind.out" "$binary" render --backend cpu --splits 1 --spp 8 \
        --width 96 --height 96 "$scene" -o "$out/image.exr" 2>&1); then
        echo "$scene: the render failed:" >&2
        grep -v '^==' <<<"$log" >&2
        exit 1
    fi
    echo "$scene: $(awk '/I *refs:/ {print $NF}' <<<"$log") instructions"
done
