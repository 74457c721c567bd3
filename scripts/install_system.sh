#!/usr/bin/env bash
# Debian libraries that pyvista/VTK needs to render off screen without a display (EGL).
exec bash "$(dirname "$0")/apt_ensure.sh" install_system \
    libegl1 libegl-mesa0 libgl1-mesa-dri libgl1 libxrender1
