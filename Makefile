# rotsound: `make demo`, `make test`, `make bench` each run scripts/tools/setup.sh first
# (installs what is missing, quietly; idempotent).
PY      := .venv/bin/python
RANKS   ?= 2
SCENE   ?= configs/quick.yaml
# Open MPI refuses to start as root unless told; only then do we tell it.
ifeq ($(shell id -u),0)
export OMPI_ALLOW_RUN_AS_ROOT := 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM := 1
endif
MPIRUN  := mpirun -n $(RANKS)
PYTEST  := -m pytest --color=no -q

.PHONY: setup demo test test-serial test-mpi docs bench dem-data clean
setup:
	@bash scripts/tools/setup.sh

demo: setup
	$(MPIRUN) $(PY) -m solver run $(SCENE)
	$(PY) -m solver plot $(SCENE)

test: setup
	@$(MAKE) --no-print-directory test-serial test-mpi

# The serial pass on WORKERS processes (pytest-xdist, tests dealt one by one: measured 6:42 against
# 7:42 with a module per worker, whose long modules left one worker idle; a module fixture may be
# made on both), then the tests that start mpirun jobs of their own (marker spawns_ranks) alone:
# beside a busy worker their ranks starve (the rank-count test took 110 s there, 32 s alone); the
# MPI pass uses both cores through its ranks. The phase collects only the files that name the marker
# (collecting the whole suite imports every module: about 5 s of the phase's CPU).
WORKERS ?= 2
SPAWNING = $(shell grep -rl --include='test_*.py' spawns_ranks tests | sort)
test-serial:
	timeout 1200 $(PY) $(PYTEST) -n $(WORKERS) --dist load -m "not spawns_ranks" tests
	timeout 1200 $(PY) $(PYTEST) -m spawns_ranks $(SPAWNING)

test-mpi:
	timeout 1200 $(MPIRUN) $(PY) $(PYTEST) -m "not serial_only" tests

# The manual (Sphinx + MyST): HTML in docs/_build/html (open index.html); warnings are errors;
# silent when it builds.
docs: setup
	@$(PY) -m sphinx -E -W --keep-going -q -b html docs docs/_build/html

bench: setup
	$(PY) -m scripts.benchmarks.bench_all

# Remake the DEM packings in tests/data/dem/ with LAMMPS, LIGGGHTS and YADE themselves (see its
# README.md). Not part of `make test`: the tests read the committed files. MercuryDPM's files
# (mercury_3d_*) are not remade here: MercuryDPM has no Debian package; its README.md, section
# "MercuryDPM", says how it was built from its public source and the drivers compiled and run.
DEM := cd tests/data/dem &&
dem-data:
	@bash scripts/tools/setup_dem.sh
	$(DEM) lmp -in lammps_2d.in -log none -screen none
	$(DEM) lmp -in lammps_3d.in -log none -screen none
	$(DEM) lmp -in lammps_3d_friction.in -log none -screen none
	$(DEM) lmp -in lammps_2d_friction.in -log none -screen none
	$(DEM) lmp -in lammps_3d_hooke.in -log none -screen none
	$(DEM) lmp -in lammps_3d_hertz.in -log none -screen none
	$(DEM) lmp -in lammps_3d_granular.in -log none -screen none
	$(DEM) lmp -in lammps_triclinic.in -log none -screen none
	$(DEM) lmp -in lammps_3d_sheared.in -log none -screen none
	$(DEM) lmp -in lammps_3d_walls.in -log none -screen none
	$(DEM) lmp -in lammps_3d_walls_waves.in -var wave l -log none -screen none
	$(DEM) lmp -in lammps_3d_walls_waves.in -var wave t -log none -screen none
	$(DEM) liggghts -in liggghts_triclinic.in -log none > /dev/null
	$(DEM) liggghts -in liggghts_3d.in -log none > /dev/null
	$(DEM) liggghts -in liggghts_3d_friction.in -log none > /dev/null
	$(DEM) liggghts -in liggghts_bridge_pairs.in -log none > /dev/null
	$(DEM) liggghts -in liggghts_3d_wet.in -log none > /dev/null
	$(DEM) liggghts -in liggghts_3d_wet_friction.in -log none > /dev/null
	$(DEM) liggghts -in liggghts_2d_wet.in -log none > /dev/null
	$(DEM) liggghts -in liggghts_3d_walls.in -log none > /dev/null
	$(DEM) yade -n -x yade_3d.py > /dev/null
	$(DEM) yade -n -x yade_3d_friction.py > /dev/null
	$(DEM) yade -n -x yade_3d_friction.py uniform > /dev/null

clean:
	rm -rf results .venv .venv-ovito *.egg-info docs/_build
