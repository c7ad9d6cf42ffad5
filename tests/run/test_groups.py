"""Many units at once (``rotsound run --group-size G``): the ranks split into groups of G, each
solving its share of the (rho, packing) units on its own sub-communicator.  Results equal the
one-group run to the manual's rank-count tolerances (docs/scale.md) (``test_cli.rank_tolerance``), whatever the
grouping; an error or a SIGTERM in one group reaches every rank; a stopped run resumes with
another group size (units are keyed by content, not by grouping)."""

import re

import pytest
from conftest import COMM, assert_all, run_cli, scene_of
from test_cli import assert_within_rank_tolerance, contents, fit_sensitivity, rank_runs  # noqa: F401 (a fixture)

from solver import parallel, pipeline
from solver.errors import InputError, Interrupted

# 2 rho x 2 packings = 4 tasks; slicing with K/Q, spectral waves and the analysis: ~1 s.


def small(path):
    return scene_of(path, cache="off", seed=6, packing={"n": 64, "phi": 0.9, "count": 2}, model={"rho": [0.5, 1.0]},
                    spectrum={"energies": True}, waves={"n": [1, 2], "method": "spectral", "t_end": 20})


def test_groups_split_consecutive_ranks_and_deal_tasks_in_a_snake():
    """Groups of 1 on any rank count: group g is rank g, task t goes to group t % count on even
    laps of count tasks and to count - 1 - t % count on odd ones, and share() gives every rank
    every task's result, taken from its owner, in task order."""
    tasks = list(range(7))
    with parallel.Groups(COMM) as one:
        assert_all(one.count == 1 and one.local is COMM and one.mine(tasks) == tasks, "one group of all ranks")
        assert_all(parallel.label(one.local) == "", "no prefix for a single group")
    with parallel.Groups(COMM, 1) as groups:
        assert_all(groups.count == COMM.size and groups.local.size == 1 and groups.index == COMM.rank,
                   f"rank {COMM.rank}: group {groups.index} of {groups.count}")
        snake = [t for t in tasks if (t % COMM.size if t // COMM.size % 2 == 0 else COMM.size - 1 - t % COMM.size) == COMM.rank]
        assert_all(groups.mine(tasks) == snake, f"rank {COMM.rank}: {groups.mine(tasks)}")
        if COMM.size == 2:
            assert_all([groups.owner(t) for t in tasks] == [0, 1, 1, 0, 0, 1, 1], "0, 1, 1, 0, ... for two groups")
        label = "" if COMM.size == 1 else f"[group {COMM.rank + 1}/{COMM.size}] "
        assert_all(parallel.label(groups.local) == label, repr(parallel.label(groups.local)))
        shared = groups.share({f"t{t}": (t, COMM.rank) for t in groups.mine(tasks)},
                              {f"t{t}": groups.owner(t) for t in tasks})
        assert_all(list(shared.items()) == [(f"t{t}", (t, groups.owner(t))) for t in tasks], str(shared))
    for bad in (0, COMM.size + 1):
        with pytest.raises(ValueError, match="does not divide"):
            parallel.Groups(COMM, bad)


def _matrix_lines(log):
    """{(rho, packing)} of the 'matrix' progress lines of a log, with their prefixes."""
    return {(m.group(1), float(m.group(2)), int(m.group(3)))
            for m in re.finditer(r"^(\[group \d+/\d+\] )?matrix rho = (\S+), packing (\d+):", log, re.M)}


@pytest.mark.mpi
@pytest.mark.timeout(240)
def test_groups_of_one_rank_equal_one_group_of_all(shared_tmp, capsys):
    """In-process on every rank: groups of 1 against one group of all ranks.  Every dataset and
    attribute agrees to the rank-count tolerances; each rank solved (and printed, prefixed with
    its group) exactly its share of the snake deal, from the largest rho down; the unit summary, printed once, counts every
    group's units (before the counts were gathered it would count rank 0's group only)."""
    ref = shared_tmp / "all.h5"
    pipeline.run(small(ref), COMM, [])
    capsys.readouterr()
    got = shared_tmp / "ones.h5"
    pipeline.run(small(got), COMM, [], group_size=1)
    log = capsys.readouterr().out
    tasks = [(rho, p) for rho in (1.0, 0.5) for p in (0, 1)]  # dealt 0, 1, 1, 0 on 2 groups
    with parallel.Groups(COMM, 1) as groups:
        mine = {(f"[group {COMM.rank + 1}/{COMM.size}] ", rho, p) for rho, p in groups.mine(tasks)}
    assert_all(_matrix_lines(log) == mine, f"rank {COMM.rank}: {sorted(_matrix_lines(log))}")
    summary = [line for line in log.splitlines() if line.startswith("units:")]
    expected = ["units: matrices 4 computed; packings 2 computed; spectra 4 computed; spectrum_windows 8 computed; "
                f"waves 12 computed (folder {got}.units; cache off)"] if COMM.rank == 0 else []
    assert_all(summary == expected, f"rank {COMM.rank}: {summary}")
    assert_within_rank_tolerance(contents(got), contents(ref), fit_sensitivity(ref), "groups of 1")


@pytest.mark.mpi
@pytest.mark.skipif(COMM.size != 2, reason="checks the units of 2 groups of 1 rank")
@pytest.mark.timeout(120)
@pytest.mark.parametrize("failure", [ValueError("injected in the last group"),
                                     InputError("injected in the last group")], ids=["ValueError", "InputError"])
@pytest.mark.parametrize("first_group_stopped", [False, True], ids=["alone", "while-group-1-stopped"])
def test_error_in_one_group_raises_on_every_rank(shared_tmp, monkeypatch, failure, first_group_stopped):
    """The last group fails in its first task (and, in one variant, group 1 is stopped by SIGTERM
    at the same time): every rank raises the error itself -- an error outranks an interruption --
    nobody is left waiting (the timeout), and the units group 1 finished are kept."""
    compute = pipeline._compute

    def failing(*args, **kwargs):
        if COMM.rank == COMM.size - 1:
            raise failure
        if first_group_stopped:
            pipeline._TERMINATE[0] = True  # as SIGTERM would, during group 1's first task
        return compute(*args, **kwargs)

    monkeypatch.setattr(pipeline, "_compute", failing)
    out = shared_tmp / f"failing_{type(failure).__name__}_{first_group_stopped}.h5"
    caught = None
    try:
        pipeline.run(small(out), COMM, [], group_size=1)
    except Exception as exc:  # noqa: BLE001 - checked below
        caught = exc
    finally:
        pipeline._TERMINATE[0] = False
    assert_all(type(caught) is type(failure) and "injected in the last group" in str(caught),
               f"rank {COMM.rank} raised {caught!r}")
    kept = sorted(p.name for p in (shared_tmp / (out.name + ".units")).glob("matrices__*.h5"))
    # group 1's tasks in the snake deal, from the largest rho down: (rho 1, packing 0), then (rho 0.5, packing 1)
    assert_all(kept == (["matrices__r01_p0000.h5"] if first_group_stopped else
                        ["matrices__r00_p0001.h5", "matrices__r01_p0000.h5"]), str(kept))
    assert_all(not out.exists(), "no results file")


@pytest.mark.mpi
@pytest.mark.skipif(COMM.size != 2, reason="counts the units of 2 groups of 1 rank")
@pytest.mark.timeout(240)
def test_sigterm_in_one_group_stops_every_rank_and_resumes_with_another_group_size(shared_tmp, monkeypatch,
                                                                                    capsys):
    """Groups of 1 on 2 ranks: group 2 (rank 1) gets SIGTERM during its first task, (rho 1,
    packing 1); group 1 never does and finishes both its tasks.  Every rank raises Interrupted
    once the groups are done; the rerun as one group of 2 resumes the 3 finished tasks, computes
    the last, and equals an uninterrupted one-group run to the rank-count tolerances."""
    ref = shared_tmp / "ref.h5"
    pipeline.run(small(ref), COMM, [])
    compute = pipeline._compute

    def then_stop(*args, **kwargs):
        compute(*args, **kwargs)
        if COMM.rank == 1:
            pipeline._TERMINATE[0] = True  # as the SIGTERM handler would, on rank 1 only

    monkeypatch.setattr(pipeline, "_compute", then_stop)
    out = shared_tmp / "stopped.h5"
    caught = None
    try:
        pipeline.run(small(out), COMM, [], group_size=1)
    except Interrupted as exc:
        caught = exc
    finally:
        pipeline._TERMINATE[0] = False
    assert_all(isinstance(caught, Interrupted), f"rank {COMM.rank} raised {caught!r}")
    monkeypatch.setattr(pipeline, "_compute", compute)
    capsys.readouterr()
    pipeline.run(small(out), COMM, [], group_size=2)
    log = capsys.readouterr().out
    if COMM.rank == 0:
        assert ("matrices 1 computed, 3 resumed; packings 2 resumed; spectra 1 computed, 3 resumed; "
                "spectrum_windows 2 computed; waves 3 computed, 9 resumed") in log, log
    assert_within_rank_tolerance(contents(out), contents(ref), fit_sensitivity(ref), "resumed as one group")


@pytest.mark.spawns_ranks
@pytest.mark.serial_only  # launches its own mpirun
def test_cli_groups_on_2_and_4_ranks_equal_one_group(rank_runs):
    """`rotsound run --group-size G` of the rank-count scene (slicing, spectral waves and the
    analysis; KPM and Verlet waves): 2 ranks in groups of 1 and 4 ranks (oversubscribed) in
    groups of 2 against 2 ranks in one group (the rank-count test's run, shared), every dataset
    and attribute to the rank-count tolerances; the group size is recorded; progress lines carry
    their group."""
    runs = {"one": rank_runs(2), "ones": rank_runs(2, "--group-size", "1"), "twos": rank_runs(4, "--group-size", "2")}
    logs = {name: log for name, (log, _) in runs.items()}
    assert "[group" not in logs["one"] and "[group 2/2] matrix rho = 0.2, packing 0" in logs["ones"], logs["ones"]
    assert "2 groups of 2 ranks share the 4 (rho, packing) tasks" in logs["twos"], logs["twos"]
    for doc in "ab":
        ref = contents(f"{runs['one'][1]}_{doc}.h5")
        fit_change = fit_sensitivity(f"{runs['one'][1]}_{doc}.h5")
        for name, size in (("ones", 1), ("twos", 2)):
            got = contents(f"{runs[name][1]}_{doc}.h5")
            assert got["@group_size"] == size and ref["@group_size"] == 2, (got["@group_size"], ref["@group_size"])
            assert_within_rank_tolerance(got, ref, fit_change, (name, doc))


@pytest.mark.timeout(120)
def test_a_sigterm_in_an_earlier_scene_stops_the_next_before_its_packings(shared_tmp):
    """A SIGTERM received during one scene of a file (the flag its handler sets, on rank 0 only)
    stops the next scene on every rank before it makes a packing or claims its output: the run
    once went on to generate the next scene's packings (an hour of FIRE near jamming) first."""
    out = shared_tmp / "next.h5"
    pipeline._TERMINATE[0] = COMM.rank == 0
    try:
        with pytest.raises(Interrupted):
            pipeline.run(small(out), COMM, [])
    finally:
        pipeline._TERMINATE[0] = False
    assert_all(not out.exists() and not (shared_tmp / "next.h5.units").exists(), "nothing of the scene was made")
