#!/usr/bin/env bash
# Debian libraries that pyvista/VTK needs to render off screen without a display (EGL).
# Idempotent: exits at once when they are present.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
pkgs=(libegl1 libegl-mesa0 libgl1-mesa-dri libgl1 libxrender1)
missing=()
for p in "${pkgs[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" -ne 0 ]; then
    echo "install_system: need root to apt-get install ${missing[*]}" >&2
    exit 1
fi
echo "install_system: installing ${missing[*]}"
apt-cache show "${missing[@]}" >/dev/null 2>&1 || apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
