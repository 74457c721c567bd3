#!/usr/bin/env bash
# Install Debian's OpenFOAM (v1912 binaries) plus the tools needed to build the
# stepServerDisplacement plugin (g++, make, flex) and to run it in parallel (Open MPI).
# Idempotent and non-interactive; exits at once when all is present.
#
# Usage: sudo scripts/install_openfoam.sh      (root required for apt-get)
set -euo pipefail
bash "$(dirname "$0")/apt_ensure.sh" install_openfoam \
    openfoam g++ make flex openmpi-bin libopenmpi-dev bzip2 xz-utils
command -v pimpleFoam >/dev/null || { echo "install_openfoam: pimpleFoam not on PATH" >&2; exit 1; }
