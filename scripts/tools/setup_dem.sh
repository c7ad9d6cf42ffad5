#!/usr/bin/env bash
# Install the DEM programs that made tests/data/dem/ (Debian 12), idempotently; silent when
# nothing is missing. Only `make dem-data` needs them: the tests read the committed files.
#   lammps 20220106 (+ its Python module, which finds the library only with liblammps-dev),
#   liggghts 3.8.0, python3-yade 2023.02a and yade: python3-yade alone does not import (its
#   dist-packages link points at a missing directory and it needs IPython); the `yade` launcher
#   runs scripts headless (yade -n -x script.py).
set -euo pipefail
cd "$(dirname "$0")/../.."

PKGS=(lammps python3-lammps liblammps-dev liggghts python3-yade yade)

bash scripts/tools/apt_install.sh "${PKGS[@]}"
