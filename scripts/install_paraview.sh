#!/usr/bin/env bash
# Debian's ParaView 5.11 with its Python (pvpython, pvbatch) and Xvfb to render without a
# display. About 2-3 minutes and 550 MB on a fresh machine; exits at once when present.
# libgl1-mesa-dri: Mesa's software OpenGL, which pvbatch draws with inside Xvfb (named here
# because --no-install-recommends would otherwise depend on another package pulling it in).
# Video: ParaView's own Ogg Theora writer (libtheora comes with paraview), no ffmpeg needed.
exec bash "$(dirname "$0")/apt_ensure.sh" install_paraview \
    paraview python3-paraview xvfb xauth libgl1-mesa-dri
