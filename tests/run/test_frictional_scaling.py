"""scripts/tools/frictional_scaling.py's plateau onset omega*, on vDOS whose onset is known."""

import numpy as np
import pytest

from scripts.tools import frictional_scaling

pytestmark = pytest.mark.serial_only  # plain numpy


@pytest.mark.parametrize("knee", [0.3, 0.55])
def test_onset_of_a_ramp_to_a_plateau(knee):
    """D = 0.4 min(omega / knee, 1), then a band: D_p = 0.4 over [0.8, 1.2], and D reaches
    D_p / 2 at omega = knee / 2, exactly (linear between bin centres)."""
    edges = np.linspace(0.0, 3.0, 151)
    centres = 0.5 * (edges[1:] + edges[:-1])
    density = 0.4 * np.minimum(centres / knee, 1.0) + np.where(centres > 1.5, 0.3, 0.0)
    star, plateau = frictional_scaling.onset(edges, density)
    assert plateau == pytest.approx(0.4, rel=1e-12, abs=0.0)
    assert star == pytest.approx(knee / 2, rel=1e-12, abs=0.0)
