"""What the waves' log line says of the energy a damped or LAMMPS run lost (waves/unit.py):
a fall as "lost", a rise (which dashpots and sliding contacts cannot give) as a gain with what
made it, never as a negative loss; and counts in the number they ask for (solver/wording.py)."""

import types

import numpy as np
import pytest

from solver.waves import unit
from solver.wording import counted

pytestmark = pytest.mark.serial_only  # string formatting on one process


def test_a_rise_of_energy_is_a_gain_not_a_negative_loss():
    """Three runs ending at 99.9 %, 98.4 % and 100.00884 % of E(0), with dashpots on a symmetric
    matrix: lost 0.1 to 1.6 %, gained 0.00884 % in one run, said to be the scheme's error."""
    energy = np.array([[1.0, 0.9995, 0.999], [2.0, 1.99, 1.968], [1.0, 1.0001, 1.0000884]])
    said = unit._energy_words(types.SimpleNamespace(symmetric=True, C=object()), energy, np.zeros(3), 400.0)
    assert said == ("energy taken by the dashpots (and the scheme's error) by t = 400: lost 0.1 to 1.6 %, "
                    "gained up to 0.00884 % in 1 run (the scheme's error: dashpots only take energy)"), said
    assert "-" not in unit._loss_words(energy[2:], "why"), unit._loss_words(energy[2:], "why")
    assert unit._loss_words(energy[:2], "why") == "lost 0.1 to 1.6 %"
    assert unit._loss_words(energy[[0, 0]], "why") == "lost 0.1 %"


def test_counts_in_their_number():
    assert [counted(n, "configuration") for n in (0, 1, 2)] == ["0 configurations", "1 configuration",
                                                                "2 configurations"]
    assert counted(1, "packing") == "1 packing" and counted(3, "matrix", "matrices") == "3 matrices"
