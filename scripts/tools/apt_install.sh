#!/usr/bin/env bash
# Install the Debian packages named as arguments that are missing, quietly (scripts/tools/setup.sh and
# scripts/tools/setup_dem.sh). As root: apt-get, waiting up to 10 min for another apt's lock; otherwise
# print the exact command and exit 1. Prints nothing when nothing is missing.
set -euo pipefail
missing=()
for p in "$@"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" -ne 0 ]; then
  echo "rotsound setup: missing Debian packages. Run, then retry:" >&2
  echo "  sudo apt-get update && sudo apt-get install -y --no-install-recommends ${missing[*]}" >&2
  exit 1
fi
echo "rotsound setup: installing ${missing[*]}" >&2
apt-get update -qq -o DPkg::Lock::Timeout=600 >/dev/null
DEBIAN_FRONTEND=noninteractive DEBCONF_NOWARNINGS=yes apt-get install -y -qq -o DPkg::Lock::Timeout=600 --no-install-recommends \
  "${missing[@]}" >/dev/null
