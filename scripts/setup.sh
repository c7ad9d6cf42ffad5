#!/usr/bin/env bash
# Install what rotsound needs on Debian 12, idempotently; silent when nothing is missing.
#   - Debian's PETSc/SLEPc stack (ABI-matched with Debian's numpy) and LAMMPS (packing.engine:
#     lammps; its Python module finds the library only with liblammps-dev) via apt, only if absent;
#   - .venv made from /usr/bin/python3 with --system-site-packages;
#   - the project installed editable into .venv without touching numpy/petsc4py.
set -euo pipefail
cd "$(dirname "$0")/.."

PKGS=(python3-petsc4py python3-slepc4py python3-mpi4py python3-h5py-mpi python3-scipy
      python3-matplotlib python3-yaml python3-numba python3-pytest python3-pytest-timeout openmpi-bin
      python3-venv lammps python3-lammps liblammps-dev)  # LAMMPS: packing.engine, its tests

bash scripts/apt_install.sh "${PKGS[@]}"

if [ ! -x .venv/bin/python ]; then
  /usr/bin/python3 -m venv --system-site-packages .venv
fi
stamp=.venv/.rotsound-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  .venv/bin/python -m pip install -q --no-deps --no-build-isolation --disable-pip-version-check -e . >/dev/null
  touch "$stamp"
fi
