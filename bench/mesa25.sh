#!/usr/bin/env bash
# Unpacks Mesa 25's lavapipe from Debian 12's bookworm-backports into a folder of its own,
# beside the stock Mesa 22.3 driver, and prints the VK_ICD_FILENAMES setting that selects it:
#
#   bench/mesa25.sh /tmp/mesa25
#   VK_ICD_FILENAMES=/tmp/mesa25/lvp_icd.json ./target/release/pathlight info
#
# Nothing on the system changes except apt's package lists: the backports source is added
# for one `apt-get download` and removed again. Mesa 25 renders the same images and runs the
# kernel 1.3-1.6x faster, but compiles it about 3x slower on an empty shader cache, which is
# why the tests stay on the stock driver (bench/RESULTS.md, eighteenth and twenty-fifth
# sessions). Needs root and Debian 12 (bookworm).
set -euo pipefail
dest="${1:?usage: bench/mesa25.sh DEST_DIR}"
if [ "$(id -u)" != 0 ] || ! grep -q bookworm /etc/os-release; then
    echo "bench/mesa25.sh: needs root on Debian 12 (bookworm)" >&2
    exit 1
fi
mkdir -p "$dest"
dest="$(cd "$dest" && pwd)"
sources=/etc/apt/sources.list.d/pathlight-bookworm-backports.sources
trap 'rm -f "$sources"; apt-get update -qq' EXIT
cat > "$sources" <<'EOF'
Types: deb
URIs: http://deb.debian.org/debian
Suites: bookworm-backports
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
EOF
apt-get update -qq
# apt-get download writes into the current folder; _apt cannot write to every folder.
(cd "$dest" && apt-get download -qq -t bookworm-backports mesa-vulkan-drivers 2>/dev/null || \
    apt-get download -t bookworm-backports mesa-vulkan-drivers)
deb="$(ls "$dest"/mesa-vulkan-drivers_*bpo12*_amd64.deb | tail -1)"
dpkg-deb -x "$deb" "$dest/root"
lib="$dest/root/usr/lib/x86_64-linux-gnu/libvulkan_lvp.so"
[ -f "$lib" ] || { echo "bench/mesa25.sh: $deb has no lavapipe" >&2; exit 1; }
python3 - "$dest/root/usr/share/vulkan/icd.d/lvp_icd.json" "$lib" "$dest/lvp_icd.json" <<'EOF'
import json, sys
icd = json.load(open(sys.argv[1]))
icd["ICD"]["library_path"] = sys.argv[2]
json.dump(icd, open(sys.argv[3], "w"), indent=4)
EOF
echo "VK_ICD_FILENAMES=$dest/lvp_icd.json"
