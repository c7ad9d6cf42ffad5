"""rotsound's stdout holds what it prints and nothing else: no terminal escape codes from a library.

Numba colours its error messages with colorama where colorama is installed; colorama's exit handler
then writes a reset code (ESC[0m) to every rank's stdout under mpirun, which breaks anyone parsing
the output (issue 58: the 4-rank counting test read '\\x1b[0m\\x1b[0m...' as its JSON). The setup
script installs python3-colorama so that this runs where the leak can happen.
"""

import subprocess
import sys

import pytest
from conftest import REPO, child_env, mpirun

# A compiled kernel of the packing stage, loaded (or compiled) and called once; prints its result.
KERNEL = ("import numpy as np, solver.packing.pair_forces as pf; "
          "print(pf.largest_squared_move(np.zeros((2, 2)), np.ones((2, 2))))")


@pytest.mark.serial_only  # starts an mpirun of its own
def test_a_compiled_kernel_under_mpirun_prints_no_escape_code():
    probe = subprocess.run([sys.executable, "-c", "import colorama"], capture_output=True, env=child_env())
    assert probe.returncode == 0, "colorama is missing: scripts/tools/setup.sh installs python3-colorama"
    run = subprocess.run([*mpirun(1), sys.executable, "-c", KERNEL], capture_output=True, cwd=REPO,
                         env=child_env(), timeout=120)
    assert run.returncode == 0, run.stderr.decode()
    assert run.stdout == b"2.0\n"  # the kernel's answer, |1 - 0|^2 summed over one particle's 2 axes
    assert b"\x1b" not in run.stderr
