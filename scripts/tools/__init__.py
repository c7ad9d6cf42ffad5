"""Tools that are not rotsound's commands: setting up a machine, rendering parts of the manual and
tables of the findings from results files, the numerical stress cases.  Not part of the installed
package; the Python tools run from the repository's root as modules, the shell scripts as files:

- ``setup.sh`` (``make setup``; every make target runs it), ``apt_install.sh`` (the Debian packages
  it and setup_dem.sh install), ``setup_dem.sh`` (LAMMPS, LIGGGHTS and YADE for ``make
  dem-data``), ``cluster_job.sh`` (a Slurm job for configs/paper.yaml);
- ``render_bad_inputs.py`` (the table of docs/bad_inputs.md from the catalogue ``bad_inputs.py``,
  which tests/io/test_bad_inputs.py runs row by row);
- ``stress.py`` (STRESS.md);
- the tables of the findings: ``frictional_table.py``, ``frictional_scaling.py``
  (docs/frictional_sound.md), ``damping_rates.py``, ``damping_table.py`` (docs/damped_sound.md),
  ``rayleigh_table.py`` (docs/rayleigh.md; its output ``rayleigh_table.md`` beside it).

    python -m scripts.tools.stress
    python -m scripts.tools.frictional_table results/frictional_mu0.h5 ...
"""
