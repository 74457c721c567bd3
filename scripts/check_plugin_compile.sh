#!/usr/bin/env bash
# Compile check of the plugin against another OpenFOAM release's source tree, without linking:
# every translation unit of Make/files through g++ -fsyntax-only, with the tree's own wmake
# flags (`wmake -show-compile-cxx`: -std, -DOPENFOAM=<api>, warnings) and the include paths wmake
# would use (Make/options' EXE_INC, -iquote ., lnInclude of src/OpenFOAM and OSspecific/POSIX).
# It needs only the tree's src/, wmake/ and META-INFO/, no build of OpenFOAM.
#
#   check_plugin_compile.sh TREE                 an extracted tree (src/ wmake/ META-INFO/)
#   check_plugin_compile.sh --git GITDIR COMMIT  that commit of an OpenFOAM git repository,
#                                                extracted into build/openfoam-check/ once
#
# Writes build/openfoam-check/<api>-<label>.log; exits 1 when a unit does not compile.
set -euo pipefail
t0=$SECONDS
say() { echo "check_plugin_compile: [$((SECONDS - t0)) s] $*"; }
die() { echo "check_plugin_compile: ERROR: $*" >&2; exit 1; }

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
plugin=$repo/adapter/foam/plugin
out=$repo/build/openfoam-check
mkdir -p "$out"

if [ "${1:-}" = "--git" ]; then
    [ $# -eq 3 ] || die "usage: $0 --git GITDIR COMMIT"
    gitdir=$2
    commit=$(git --git-dir="$gitdir" rev-parse --verify "$3^{commit}") || die "no commit $3 in $gitdir"
    api=$(git --git-dir="$gitdir" show "$commit:META-INFO/api-info" | sed -n 's/^api=//p')
    tree=$out/tree-$api-${commit:0:10}
    if [ ! -f "$tree/.extracted" ]; then
        say "extracting src/ wmake/ etc/ bin/ META-INFO/ of $commit (api $api)"
        rm -rf "$tree" && mkdir -p "$tree"
        git --git-dir="$gitdir" archive "$commit" src wmake etc bin META-INFO | tar -x -C "$tree"
        touch "$tree/.extracted"
    fi
    label=${commit:0:10}
else
    [ $# -eq 1 ] || die "usage: $0 TREE | --git GITDIR COMMIT"
    tree=$(cd "$1" && pwd)
    label=$(basename "$tree")
fi
[ -f "$tree/META-INFO/api-info" ] && [ -x "$tree/wmake/wmake" ] \
    || die "$tree is not an OpenFOAM.com source tree (META-INFO/api-info, wmake/wmake)"
api=$(sed -n 's/^api=//p' "$tree/META-INFO/api-info")
patch=$(sed -n 's/^patch=//p' "$tree/META-INFO/api-info")

# the wmake variables of a Gcc, double precision, 32-bit label build (Debian's, and the usual)
export WM_PROJECT_DIR=$tree WM_PROJECT=OpenFOAM WM_PROJECT_VERSION=v$api
export WM_ARCH=linux64 WM_COMPILER=Gcc WM_COMPILER_TYPE=system WM_COMPILER_LIB_ARCH=64
export WM_COMPILE_OPTION=Opt WM_PRECISION_OPTION=DP WM_LABEL_SIZE=32 WM_LABEL_OPTION=Int32
export WM_OPTIONS=linux64GccDPInt32Opt WM_MPLIB=SYSTEMOPENMPI WM_OSTYPE=POSIX
export WM_DIR=$tree/wmake FOAM_SRC=$tree/src LIB_SRC=$tree/src
export PATH=$WM_DIR:$PATH
unset WM_PROJECT_USER_DIR MAKEFLAGS MFLAGS MAKELEVEL   # under make: no "Entering directory" in -show-*

if [ ! -f "$tree/.wmake-tools" ]; then
    say "building wmake's tools"
    make -s -C "$WM_DIR/src" >/dev/null 2>&1 || die "building wmake's tools failed"
    touch "$tree/.wmake-tools"
fi
# the folders of Make/options' EXE_INC (and OpenFOAM's own) need their lnInclude trees
exe_inc=$(sed -n '/^EXE_INC/,/^$/p' "$plugin/Make/options" | sed 's/^EXE_INC *=//; s/\\$//' \
          | sed "s|\$(LIB_SRC)|$tree/src|g" | tr '\n' ' ')
if [ ! -f "$tree/.lninclude" ]; then
    say "creating lnInclude trees"
    for d in "$tree/src/OpenFOAM" "$tree/src/OSspecific/POSIX" \
             $(printf '%s\n' $exe_inc | sed -n 's|^-I\(.*\)/lnInclude$|\1|p'); do
        wmakeLnInclude -silent "$d" >/dev/null 2>&1 || die "wmakeLnInclude $d failed"
    done
    touch "$tree/.lninclude"
fi

known=$(sed -n 's/^ *known-apis: *//p' "$plugin/common/whaleFoamCompat.H")
if [[ " $known " == *" $api "* ]]; then
    say "api $api is a release the plugin knows (common/whaleFoamCompat.H, known-apis: $known)"
else
    say "api $api is not in common/whaleFoamCompat.H's known-apis ($known): checking it anyway"
fi
cxx=$(cd "$plugin" && wmake -show-compile-cxx) || die "wmake -show-compile-cxx failed in $tree"
log=$out/$api-$label.log
say "OpenFOAM api $api (patch $patch) at $tree: $cxx"
: > "$log"
failed=()
for unit in $(grep -v '^ *$' "$plugin/Make/files" | grep '\.C$'); do
    # shellcheck disable=SC2086  # the flags are words
    if (cd "$plugin" && $cxx -fsyntax-only $exe_inc -iquote. \
            -I"$tree/src/OpenFOAM/lnInclude" -I"$tree/src/OSspecific/POSIX/lnInclude" \
            "$unit") >> "$log" 2>&1; then
        echo "ok     $unit"
    else
        echo "FAILED $unit"
        failed+=("$unit")
    fi
done
[ ${#failed[@]} -eq 0 ] || die "${#failed[@]} unit(s) do not compile against api $api: ${failed[*]}; log: $log"
warnings=$(grep -c 'warning:' "$log" || true)
say "all units compile against OpenFOAM api $api (patch $patch), $warnings warning(s); log: $log"
