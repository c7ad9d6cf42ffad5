"""A generated packing that does not jam stops the run with one InputError naming packing.phi,
before any solver runs, whether the packing was just made, resumed from the units folder or taken
from the cache (the command line on 2 ranks: tests/io/bad_inputs.py, rows 'packing does not jam')."""

import numpy as np
import pytest
from conftest import COMM, assert_all, scene_of, star_cluster

from solver import pipeline
from solver.errors import InputError
from solver.model import dynmat
from solver.packing import configuration, jammed
from solver.packing import mechanics

UNJAMMED = dict(seed=0, packing={"n": 256, "phi": 0.8}, model={"rho": 1}, spectrum={},
                waves={"n": [1], "method": "spectral", "t_end": 10})
"""Below jamming (scene_of's sections; the cache is the test's)."""


def no_solver(*args, **kwargs):
    raise AssertionError("a matrix was assembled for a packing that did not jam")


def test_unjammed_packing_is_refused_before_any_solver_from_any_source(shared_tmp, monkeypatch):
    """phi = 0.8 is below jamming for this mixture: all 256 disks are rattlers.  The run stops in
    the packing stage (assembly would fail the test), the message names packing.phi, the
    configuration, the rattlers, the pressure and where the mixture jams.  The packing unit is
    kept, so a rerun (units folder) and another output sharing the cache refuse it again without
    running FIRE.  Before the fix the matrix had 0 DOF and SLEPc died of a floating-point
    exception (SIGFPE, MPI_ABORT)."""
    monkeypatch.setattr(dynmat, "assemble", no_solver)
    cache = shared_tmp / "cache"

    def refused(out):
        with pytest.raises(InputError) as caught:
            pipeline.run(scene_of(shared_tmp / out, cache=str(cache), **UNJAMMED), COMM, [])
        return str(caught.value)

    message = refused("first.h5")
    assert_all(message.startswith("packing.phi = 0.8: configuration 0 did not jam: all 256 disks are "
                                  "rattlers (pressure ") and "jams near phi = 0.84" in message, message)
    monkeypatch.setattr(jammed, "generate", no_solver)  # from here on FIRE must not run either
    assert_all(refused("first.h5") == message, "resumed from the units folder: the same refusal")
    assert_all(refused("second.h5") == message, "taken from the cache: the same refusal")
    assert_all(not (shared_tmp / "first.h5").exists() and not (shared_tmp / "second.h5").exists(),
               "no results file written")


def test_a_floppy_cluster_is_refused_and_a_jammed_packing_is_not(small_packing):
    """The rigidity count: N' non-rattlers need 2N' - 1 contacts among them.  The 64-disk jammed
    packing passes; the same packing with all but one disk and its contact neighbours flagged as
    rattlers (a star and the few contacts between its arms) fails, as does one with every disk a
    rattler; each message says what was found."""
    assert_all(mechanics.jamming_failure(small_packing) is None, "a jammed packing is accepted")
    p = small_packing
    cluster, n_cluster, inside = star_cluster(p)
    assert_all(inside < 2 * n_cluster - 1, f"the test's cluster: {n_cluster} disks, {inside} contacts")
    floppy = configuration.Packing(p.positions, p.diameters, p.box, ~cluster, p.info)
    why = mechanics.jamming_failure(floppy)
    assert_all(why is not None and why.startswith(f"only {n_cluster} of 64 disks are not rattlers and they "
                                                  f"share {inside} contacts, fewer than the 2N' - 1 = "
                                                  f"{2 * n_cluster - 1}"), why)
    loose = configuration.Packing(p.positions, p.diameters, p.box, np.ones(p.n, dtype=bool), p.info)
    why = mechanics.jamming_failure(loose)
    assert_all(why is not None and why.startswith("all 64 disks are rattlers"), why)
    with pytest.raises(InputError, match=r"packing.phi = 0.9: configurations 1, 2 of 3 did not jam "
                                         r"\(configuration 1: only"):
        jammed.require_jammed([p, floppy, loose], 0.9)
