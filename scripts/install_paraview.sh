#!/usr/bin/env bash
# Debian's ParaView 5.11 with its Python (pvpython, pvbatch) and Xvfb to render without a
# display. About 2 minutes and 550 MB on a fresh machine; exits at once when present.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
pkgs=(paraview python3-paraview xvfb xauth)
missing=()
for p in "${pkgs[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" -ne 0 ]; then
    echo "install_paraview: need root to apt-get install ${missing[*]}" >&2
    exit 1
fi
echo "install_paraview: installing ${missing[*]} (about 2 minutes)"
apt-cache show "${missing[@]}" >/dev/null 2>&1 || apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install_paraview: done"
