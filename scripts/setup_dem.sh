#!/usr/bin/env bash
# Install the DEM programs that made tests/data/dem/ (Debian 12), idempotently; silent when
# nothing is missing. Only `make dem-data` needs them: the tests read the committed files.
#   lammps 20220106 (+ its Python module, which finds the library only with liblammps-dev),
#   liggghts 3.8.0, python3-yade 2023.02a and yade: python3-yade alone does not import (its
#   dist-packages link points at a missing directory and it needs IPython); the `yade` launcher
#   runs scripts headless (yade -n -x script.py).
set -euo pipefail
cd "$(dirname "$0")/.."

PKGS=(lammps python3-lammps liblammps-dev liggghts python3-yade yade)

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" -ne 0 ]; then
    echo "rotsound setup_dem: missing Debian packages. Run, then retry:" >&2
    echo "  sudo apt-get update && sudo apt-get install -y --no-install-recommends ${missing[*]}" >&2
    exit 1
  fi
  echo "rotsound setup_dem: installing ${missing[*]}" >&2
  apt-get update -qq -o DPkg::Lock::Timeout=600 >/dev/null
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq -o DPkg::Lock::Timeout=600 --no-install-recommends "${missing[@]}" >/dev/null
fi
