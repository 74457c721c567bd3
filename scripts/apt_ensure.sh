#!/usr/bin/env bash
# apt_ensure.sh NAME PACKAGE...: install the Debian packages that are missing, non-interactively.
# Exits at once when all are installed; runs `apt-get update` only when a package cannot be
# resolved from the current lists. Root is needed for an install. NAME prefixes the messages.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
name=$1
shift
missing=()
for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" -ne 0 ]; then
    echo "$name: need root to apt-get install ${missing[*]}" >&2
    exit 1
fi
echo "$name: installing ${missing[*]}"
lock=(-o DPkg::Lock::Timeout=600)  # another apt may hold the lock: wait up to 10 minutes
install() { apt-get install -y -qq --no-install-recommends "${lock[@]}" "${missing[@]}" >/dev/null; }
# a stale or missing package list: refresh it and try once more
apt-cache show "${missing[@]}" >/dev/null 2>&1 || apt-get update -qq "${lock[@]}"
install || { apt-get update -qq "${lock[@]}" && install; }
echo "$name: done"
