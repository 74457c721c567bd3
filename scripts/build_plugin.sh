#!/usr/bin/env bash
# Build the OpenFOAM boundary condition stepServerDisplacement into
#   build/lib/libstepServerDisplacement.so
# (from an installed wheel: ~/.cache/whale-adapter/build/lib/; WHALE_BUILD_DIR overrides)
#
# Two ways, chosen automatically:
#  1. $WM_PROJECT_DIR is set AND has wmake/ and src/OpenFOAM/lnInclude
#     (a full OpenFOAM development installation, environment sourced):
#     use it as is.
#  2. Otherwise (Debian's `openfoam` package: binaries only, no headers):
#     fetch Debian's source package into build/openfoam-src/ (enabling a
#     deb-src stanza if needed, root only), extract src/ wmake/ etc/ bin/,
#     build wmake's tools, wmakeLnInclude the needed folders, and compile
#     against the binaries in /usr/lib.
# Idempotent: a .so newer than the plugin sources is reused as is.
#
# Usage: scripts/build_plugin.sh [--force]
set -euo pipefail

t0=$SECONDS
say() { echo "build_plugin: [$((SECONDS - t0)) s] $*"; }
die() { echo "build_plugin: ERROR: $*" >&2; exit 1; }
done_msg() { say "$* (total $((SECONDS - t0)) s)"; }

# Two layouts: the repository (scripts/build_plugin.sh, building into build/), or an installed
# wheel (adapter/_scripts/build_plugin.sh, building into ~/.cache/whale-adapter/build, as
# adapter/resources.py expects). WHALE_BUILD_DIR overrides the build folder in both.
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
if [ -f "$here/../adapter/foam/plugin/Make/files" ]; then
    repo=$(cd "$here/.." && pwd)
    plugin_src=$repo/adapter/foam/plugin
    build=${WHALE_BUILD_DIR:-$repo/build}
else
    plugin_src=$(cd "$here/../foam/plugin" 2>/dev/null && pwd) \
        || die "plugin sources not found next to $here (neither the repository nor an installed wheel)"
    build=${WHALE_BUILD_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/whale-adapter/build}
fi
libdir=$build/lib
so=$libdir/libstepServerDisplacement.so
force=0
[ "${1:-}" = "--force" ] && force=1

[ -f "$plugin_src/Make/files" ] || die "plugin sources not found in $plugin_src"

# --- Reuse a finished build --------------------------------------------------
if [ $force -eq 0 ] && [ -f "$so" ] \
   && [ -z "$(find "$plugin_src" "$0" -type f -newer "$so" -print -quit)" ]; then
    done_msg "up to date: $so"
    exit 0
fi

# --- Tools -------------------------------------------------------------------
for tool in g++ make; do
    command -v "$tool" >/dev/null \
        || die "'$tool' not found; run scripts/install_openfoam.sh (as root)"
done

# --- Choose the OpenFOAM tree --------------------------------------------------
if [ -n "${WM_PROJECT_DIR:-}" ] && [ -d "$WM_PROJECT_DIR/wmake" ] \
   && [ -d "$WM_PROJECT_DIR/src/OpenFOAM/lnInclude" ]; then
    say "using the OpenFOAM installation at WM_PROJECT_DIR=$WM_PROJECT_DIR"
    for v in WM_OPTIONS WM_DIR FOAM_SRC FOAM_LIBBIN; do
        [ -n "${!v:-}" ] || die "WM_PROJECT_DIR is a development tree but $v is unset; source its etc/bashrc first"
    done
    command -v wmake >/dev/null || die "wmake not on PATH; source $WM_PROJECT_DIR/etc/bashrc first"
else
    [ -n "${WM_PROJECT_DIR:-}" ] \
        && say "WM_PROJECT_DIR=$WM_PROJECT_DIR has no wmake/ or src/OpenFOAM/lnInclude: using Debian's source package"
    [ -f /usr/lib/libOpenFOAM.so ] \
        || die "/usr/lib/libOpenFOAM.so not found: install Debian's openfoam first (scripts/install_openfoam.sh)"
    command -v dpkg-query >/dev/null || die "dpkg-query not found: this path needs Debian"
    bin_ver=$(dpkg-query -W -f='${Version}' openfoam 2>/dev/null) \
        || die "Debian package 'openfoam' is not installed; run scripts/install_openfoam.sh"
    upstream=${bin_ver%%-*}                       # e.g. 1912.200626

    cache=$build/openfoam-src
    tree=$cache/tree-$upstream
    mkdir -p "$cache"

    # Source tarball, matching the installed binaries' upstream version
    tarball=$cache/openfoam_${upstream}.orig.tar.bz2
    if [ ! -f "$tarball" ]; then
        say "fetching Debian's source package for openfoam $bin_ver"
        command -v apt-get >/dev/null || die "apt-get not found"
        if ! apt-get source --print-uris openfoam >/dev/null 2>&1 \
           || [ -z "$(apt-get source --print-uris openfoam 2>/dev/null | grep orig.tar)" ]; then
            srcfile=/etc/apt/sources.list.d/debian-src.sources
            [ "$(id -u)" -eq 0 ] \
                || die "no deb-src entry for Debian; as root, add $srcfile (Types: deb-src, as in debian.sources) and run apt-get update"
            if [ ! -f "$srcfile" ]; then
                say "enabling deb-src in $srcfile"
                base=/etc/apt/sources.list.d/debian.sources
                [ -f "$base" ] || die "$base not found; add a deb-src line for Debian by hand"
                # The Debian (not security) stanza, with Types: deb-src
                awk 'BEGIN{RS="";ORS="\n\n"} /URIs:[^\n]*debian\/?(\n|$)/ && !/security/ {sub(/Types: deb/,"Types: deb-src"); print}' \
                    "$base" > "$srcfile"
                grep -q "deb-src" "$srcfile" || { rm -f "$srcfile"; die "could not derive a deb-src stanza from $base"; }
            fi
            say "apt-get update"
            apt-get update -qq || die "apt-get update failed"
        fi
        (cd "$cache" && apt-get source --download-only -qq openfoam 2>&1 | grep -v "unsandboxed" || true)
        [ -f "$tarball" ] || die "apt-get source did not produce $tarball (binary $bin_ver; the source version may differ: check 'apt-cache showsrc openfoam')"
    fi

    # Extract what the build needs
    if [ ! -f "$tree/.extracted" ]; then
        say "extracting src/ wmake/ etc/ bin/ from $(basename "$tarball")"
        rm -rf "$tree" && mkdir -p "$tree"
        tar -xjf "$tarball" -C "$tree" --strip-components=1 \
            --wildcards --no-wildcards-match-slash \
            '*/src' '*/wmake' '*/etc' '*/bin' '*/META-INFO' \
            || die "extraction of $tarball failed"
        touch "$tree/.extracted"
    fi

    export WM_PROJECT_DIR=$tree WM_PROJECT=OpenFOAM WM_PROJECT_VERSION=v${upstream%%.*}
    export WM_ARCH=linux64 WM_COMPILER=Gcc WM_COMPILER_TYPE=system WM_COMPILER_LIB_ARCH=64
    export WM_COMPILE_OPTION=Opt WM_PRECISION_OPTION=DP WM_LABEL_SIZE=32 WM_LABEL_OPTION=Int32
    export WM_OPTIONS=linux64GccDPInt32Opt WM_MPLIB=SYSTEMOPENMPI
    export WM_DIR=$tree/wmake FOAM_SRC=$tree/src FOAM_LIBBIN=/usr/lib
    export PATH=$WM_DIR:$PATH
    unset WM_PROJECT_USER_DIR

    if [ ! -f "$tree/.wmake-tools" ]; then
        say "building wmake's tools"
        make -s -C "$WM_DIR/src" >/dev/null || die "building wmake's tools failed"
        touch "$tree/.wmake-tools"
    fi

    if [ ! -f "$tree/.lninclude" ]; then
        say "creating lnInclude trees"
        for d in OpenFOAM OSspecific/POSIX finiteVolume meshTools dynamicMesh \
                 fileFormats surfMesh transportModels/incompressible \
                 TurbulenceModels/turbulenceModels TurbulenceModels/incompressible; do
            wmakeLnInclude -silent "$tree/src/$d" >/dev/null 2>&1 || die "wmakeLnInclude $d failed"
        done
        touch "$tree/.lninclude"
    fi
fi

# --- Which release ----------------------------------------------------------
# OpenFOAM.com's META-INFO/api-info names the release's API (v1912: api=1912); the releases
# the plugin knows are the known-apis line of its compatibility header (docs/openfoam-plugin.md)
known=$(sed -n 's/^ *known-apis: *//p' "$plugin_src/common/whaleFoamCompat.H")
api=$(sed -n 's/^api=//p' "$WM_PROJECT_DIR/META-INFO/api-info" 2>/dev/null || true)
patch=$(sed -n 's/^patch=//p' "$WM_PROJECT_DIR/META-INFO/api-info" 2>/dev/null || true)
if [ -z "$api" ]; then
    say "WARNING: OpenFOAM ${WM_PROJECT_VERSION:-of unknown version} at $WM_PROJECT_DIR has no META-INFO/api-info: not OpenFOAM.com (ESI), perhaps the Foundation's line, which the plugin does not support (it knows OpenFOAM.com api $known); trying anyway"
elif [[ " $known " == *" $api "* ]]; then
    say "found OpenFOAM.com v$api (api $api, patch ${patch:-?}): a release the plugin knows (known: $known)"
else
    say "WARNING: found OpenFOAM.com v$api (api $api, patch ${patch:-?}): not a release the plugin knows (known: $known); trying anyway, see docs/openfoam-plugin.md"
fi

# --- Compile ---------------------------------------------------------------
# wmake writes its objects next to Make/, so build from a copy in build/
work=$build/plugin-src
mkdir -p "$work" "$libdir"
rm -rf "$work/plugin"
cp -r "$plugin_src" "$work/plugin"
export FOAM_USER_LIBBIN=$libdir
say "compiling the plugin (wmake libso)"
(cd "$work/plugin" && wmake -s libso) > "$build/plugin-build.log" 2>&1 \
    || { tail -n 40 "$build/plugin-build.log" >&2; die "wmake libso failed; full log: $build/plugin-build.log"; }
[ -f "$so" ] || die "wmake finished but $so is missing; log: $build/plugin-build.log"
touch "$so"
done_msg "built $so"
