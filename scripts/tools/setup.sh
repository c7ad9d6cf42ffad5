#!/usr/bin/env bash
# Install what rotsound needs on Debian 12, idempotently; silent when nothing is missing.
#   - Debian's PETSc/SLEPc stack (ABI-matched with Debian's numpy) and LAMMPS (packing.engine:
#     lammps; its Python module finds the library only with liblammps-dev) via apt, only if absent;
#   - .venv made from /usr/bin/python3 with --system-site-packages;
#   - the project installed editable into .venv without touching numpy/petsc4py;
#   - OVITO's Python module (PyPI only; it needs numpy >= 2, which must never reach .venv) in a venv
#     of its own, .venv-ovito, without system site packages: the export tests read the exported
#     files with OVITO's readers and render one with its Vulkan renderer (Mesa's lavapipe, no GPU).
set -euo pipefail
cd "$(dirname "$0")/../.."

PKGS=(python3-petsc4py python3-slepc4py python3-mpi4py python3-h5py-mpi python3-scipy
      python3-matplotlib python3-yaml python3-numba python3-pytest python3-pytest-timeout
      python3-pytest-xdist openmpi-bin  # the serial tests on both cores (make test)
      python3-colorama  # not rotsound's: numba colours its messages with it; the tests check no escape code leaks
      libmumps-ptscotch-5.5  # MUMPS with SCOTCH's ordering, loaded in place of the default build (solver/petscenv.py)
      python3-venv lammps python3-lammps liblammps-dev  # LAMMPS: packing.engine, its tests
      python3-ase python3-vtk9  # `rotsound export`: extended XYZ (ASE), VTK XML PolyData (VTK)
      xvfb xauth libgl1-mesa-dri  # rotsound render: VTK draws an exported file without a display
      libvulkan1 mesa-vulkan-drivers  # OVITO's renderer, Vulkan on the CPU (tests/io/ovito_check.py)
      python3-sphinx python3-myst-parser furo)  # the manual (make docs): Sphinx, Markdown pages, a theme

bash scripts/tools/apt_install.sh "${PKGS[@]}"

if [ ! -x .venv/bin/python ]; then
  /usr/bin/python3 -m venv --system-site-packages .venv
fi
# The stamp holds the checkout the editable install points at: a venv moved, or shared with another
# checkout (a git worktree), is pointed back at this one.
stamp=.venv/.rotsound-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || [ "$(cat "$stamp")" != "$PWD" ]; then
  .venv/bin/python -m pip install -q --no-deps --no-build-isolation --disable-pip-version-check -e . >/dev/null
  echo "$PWD" > "$stamp"
fi

# Debian's petsc4py/slepc4py live under /usr/lib/{petsc,slepc}dir/<version>/<arch>-real; the .pth
# files they ship look for them through the /usr/lib/petsc and /usr/lib/slepc links, which only the
# -dev packages (with compilers and every solver's headers) make.  A .pth of the venv names the
# directories the real-scalar Python packages installed instead, read from dpkg.
pth=$(.venv/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')/rotsound-debian-petsc.pth
real=$(dpkg-query -W -f='${Package} ${Status}\n' 'python3-petsc4py-real3*' 'python3-slepc4py-real3*' |
       awk '/install ok installed/ {print $1}')
dirs=$(dpkg -L $real | grep -E '/lib/python3/dist-packages$' || true)
if [ "$(cat "$pth" 2>/dev/null)" != "$dirs" ]; then
  printf '%s\n' "$dirs" > "$pth"
fi
.venv/bin/python -c 'import petsc4py, slepc4py' 2>/dev/null || {
  echo "rotsound setup: petsc4py/slepc4py do not import from .venv (looked in: $dirs)" >&2
  exit 1
}

# OVITO, pinned: the export tests rely on how its readers name and type the exported columns.
ovito=3.17.2
if [ "$(cat .venv-ovito/.rotsound-ovito 2>/dev/null)" != "$ovito" ]; then
  [ -x .venv-ovito/bin/python ] || /usr/bin/python3 -m venv .venv-ovito
  # quiet unless it fails (pip warns on stderr, e.g. of a configured index folder that is absent)
  log=$(.venv-ovito/bin/python -m pip install -q --disable-pip-version-check --root-user-action=ignore \
          "ovito==$ovito" 2>&1) || { echo "$log" >&2; echo "rotsound setup: pip install ovito==$ovito failed" >&2; exit 1; }
  echo "$ovito" > .venv-ovito/.rotsound-ovito
fi
