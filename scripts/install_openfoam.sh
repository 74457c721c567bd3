#!/usr/bin/env bash
# Install Debian's OpenFOAM (v1912 binaries) plus the tools needed to build
# the stepServerDisplacement plugin (g++, make, flex) and run it in parallel
# (Open MPI). Idempotent and non-interactive; quick exit if all is present.
#
# Usage: sudo scripts/install_openfoam.sh      (root required for apt-get)
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive

pkgs=(openfoam g++ make flex openmpi-bin libopenmpi-dev bzip2 xz-utils)

missing=()
for p in "${pkgs[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing+=("$p")
    fi
done
if [ ${#missing[@]} -eq 0 ]; then
    echo "install_openfoam: all packages present (${pkgs[*]})"
    exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
    echo "install_openfoam: need root to install: ${missing[*]}" >&2
    exit 1
fi

echo "install_openfoam: installing ${missing[*]}"
# Refresh the package lists only if they are missing or cannot resolve a package.
if ! apt-cache show "${missing[@]}" >/dev/null 2>&1; then
    echo "install_openfoam: apt-get update"
    apt-get update -qq
fi
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install_openfoam: done ($(dpkg-query -W -f='${Version}' openfoam))"
