"""The exact vDOS by counting (``spectrum.counting``): Sylvester inertias at the bin edges.

Oracles: dense ``eigvalsh`` histograms (the counts must be equal, integer for integer), fresh
factorisations at every shift (``slicing.count_below``) against the reused one, and the slicing
scene's pooled vDOS through the pipeline.  Runs on 1 and 2 ranks (edges spread over the ranks).
"""

import numpy as np
import pytest
from conftest import COMM, assert_all, assert_close, child_env, jammed_packing, scene_of

from solver.contact_law import ContactModel
from solver import pipeline
from solver.references import dense_eigenvalues
from solver.io import unit_keys
from solver.model import dynmat, operators
from solver.spectrum import counting, slicing

BIN = 0.05


@pytest.mark.parametrize("rho", [0.0, 0.5, 2.0])
def test_counts_equal_dense_eigenvalue_histogram(comm, small_packing, rho):
    dm = dynmat.assemble(small_packing, ContactModel(rho), comm)
    try:
        datasets, attrs, settings = counting.solve(dm, bin_width=BIN, zero_tol=1e-4)
        lam = dense_eigenvalues(dm)
    finally:
        dm.destroy()
    zero = np.abs(lam) < 1e-8
    expected, _ = np.histogram(np.sqrt(lam[~zero]), datasets["edges"])
    assert_all(np.array_equal(datasets["counts"], expected),
               f"counts differ from eigvalsh in bins {np.nonzero(datasets['counts'] != expected)[0]}")
    assert_all(attrs["n_zero_modes"] == zero.sum() == 2 and attrs["n_negative_modes"] == 0, str(attrs))
    assert_all(datasets["edges"][-1] > np.sqrt(lam.max()), "the last edge must lie above every mode")
    assert_close(attrs["omega_max"], np.sqrt(lam.max()), rtol=1e-8, what="omega_max (Lanczos tol 1e-8)")
    assert_all(settings["inertia"]["factor_package"] == "mumps", str(settings))
    # scripts/tools/setup.sh installs Debian's PT-Scotch MUMPS and petscenv loads it
    assert_all(settings["inertia"]["mumps_build"] == "ptscotch", str(settings))


def test_reused_factorisation_counts_like_fresh_ones(comm, small_packing):
    """Shifts out of order, so every refactorisation starts from another shift's values."""
    dm = dynmat.assemble(small_packing, ContactModel(1.0), comm)
    A = operators.scaled_operator(dm)
    try:
        top = operators.largest_omega(dm) ** 2
        shifts = top * np.array([0.6, 0.05, 0.3, 1e-9, 0.95, 0.15, 0.1, 0.8])
        got, _ = counting.counts_below(A, shifts, COMM)
        fresh = [slicing.count_below(A, float(s)) for s in shifts]
    finally:
        A.destroy()
        dm.destroy()
    assert_all(list(got) == fresh, f"{list(got)} != {fresh}")
    assert_all(len(set(fresh)) == len(fresh), f"the shifts must tell the counts apart: {fresh}")


def test_counting_scene_vdos_equals_the_slicing_histogram(shared_tmp):
    units = {m: pipeline.run(scene_of(shared_tmp / f"{m}.h5", cache="off", seed=4,
                                      packing={"n": 64, "phi": 0.9, "count": 2}, model={"rho": [0.0, 1.0]},
                                      spectrum={"method": m}), COMM, [])["units"] for m in ("counting", "slicing")}
    for r in ("r00", "r01"):
        (c, ca), (s, sa) = units["counting"][f"vdos/{r}"], units["slicing"][f"vdos/{r}"]
        m = min(c["density"].size, s["density"].size)
        assert_close(c["density"][:m], s["density"][:m], rtol=1e-12, what=f"vdos {r}")
        assert_all(not c["density"][m:].any() and not s["density"][m:].any(), "empty tail bins")
        assert_close(ca["omega_c"], sa["omega_c"], rtol=1e-8, what="omega_c (Lanczos tol 1e-8)")
        for p in ("p0000", "p0001"):
            cd, cattrs = units["counting"][f"spectra/{r}_{p}"]
            sd, sattrs = units["slicing"][f"spectra/{r}_{p}"]
            assert_all(cd["counts"].sum() == sd["omega"].size and
                       cattrs["n_zero_modes"] == sattrs["n_zero_modes"], f"{r}_{p}")


def test_low_top_estimate_extends_the_bins(comm, small_packing, monkeypatch):
    """A Lanczos omega_max that falls short (forced here to half the true value) must not lose the
    modes above it: more bins are counted up to the Gershgorin bound, and the counts still equal
    eigvalsh's histogram."""
    dm = dynmat.assemble(small_packing, ContactModel(1.0), comm)
    try:
        true_top = operators.largest_omega(dm)
        monkeypatch.setattr(counting, "largest_omega", lambda _: 0.5 * true_top)
        datasets, attrs, _ = counting.solve(dm, bin_width=BIN, zero_tol=1e-4)
        lam = dense_eigenvalues(dm)
    finally:
        dm.destroy()
    expected, _ = np.histogram(np.sqrt(lam[np.abs(lam) >= 1e-8]), datasets["edges"])
    assert_all(datasets["edges"][-1] > true_top, "bins must reach past the true omega_max")
    assert_all(np.array_equal(datasets["counts"], expected), "counts differ from eigvalsh")


def divisors(n: int) -> list[int]:
    return [d for d in range(1, n + 1) if n % d == 0]


@pytest.mark.parametrize("dim", [2, 3])
def test_shared_factorisations_count_like_dense(comm, small_packing, dim):
    """Every layout of the factorisations on this run's ranks (a factor per rank, or shared by all)
    gives the dense histogram; in 3D with rolling and twisting springs, whose factors fill in most."""
    packing = small_packing if dim == 2 else jammed_packing(128, 0.7, 5, dim=3)
    model = ContactModel(0.5) if dim == 2 else ContactModel(0.5, rho_roll=0.3, rho_twist=0.2)
    dm = dynmat.assemble(packing, model, comm)
    try:
        lam = dense_eigenvalues(dm)
        for ranks in divisors(COMM.size):
            datasets, attrs, settings = counting.solve(dm, bin_width=0.2, zero_tol=1e-4, factor_ranks=ranks)
            expected, _ = np.histogram(np.sqrt(lam[np.abs(lam) >= 1e-8]), datasets["edges"])
            assert_all(np.array_equal(datasets["counts"], expected), f"factor_ranks {ranks}: counts differ from "
                       f"eigvalsh in bins {np.nonzero(datasets['counts'] != expected)[0]}")
            layout = (settings["inertia"]["factor_ranks"], settings["inertia"]["factor_groups"])
            assert_all(layout == (ranks, COMM.size // ranks), f"{layout}")
    finally:
        dm.destroy()


FOUR_RANKS = """
import json, pickle, sys, numpy as np
from solver import petscenv
PETSc = petscenv.init([])
from solver.contact_law import ContactModel
from solver.model import dynmat
from solver.references import dense_eigenvalues
from solver.spectrum import counting
comm = PETSc.COMM_WORLD
with open(sys.argv[1], "rb") as stream:
    p = pickle.load(stream)[0]
dm = dynmat.assemble(p, ContactModel(0.5, rho_roll=0.3, rho_twist=0.2), comm)
counts = {r: counting.solve(dm, bin_width=0.2, zero_tol=1e-4, factor_ranks=r)[0]["counts"].tolist() for r in (1, 2, 4)}
lam = dense_eigenvalues(dm)
edges = 0.2 * np.arange(len(counts[1]) + 1)
if comm.rank == 0:
    print(json.dumps({"counts": counts, "dense": np.histogram(np.sqrt(lam[np.abs(lam) >= 1e-8]), edges)[0].tolist()}))
"""


def _pickled(path, *packings):
    """``path`` holding ``packings`` (pickled): each child process or rank reads them instead of
    running FIRE again (the 4096 disks: seconds each)."""
    import pickle

    with open(path, "wb") as stream:
        pickle.dump(packings, stream)
    return str(path)


@pytest.mark.spawns_ranks
@pytest.mark.serial_only
def test_four_ranks_count_alike_in_every_layout(tmp_path):
    """4 ranks (oversubscribed): factors per rank, shared by pairs, shared by all four: the same
    integers as the dense histogram (128 spheres with rolling and twisting)."""
    import json
    import subprocess
    import sys

    from conftest import mpirun

    env = child_env()
    packings = _pickled(tmp_path / "packings.pickle", jammed_packing(128, 0.7, 5, dim=3))
    done = subprocess.run(mpirun(4) + [sys.executable, "-c", FOUR_RANKS, packings], capture_output=True, text=True,
                          timeout=180, env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    for ranks, counts in out["counts"].items():
        assert counts == out["dense"], (ranks, counts, out["dense"])


BUILD = """
import json, pickle, sys, numpy as np
from solver import petscenv
PETSc = petscenv.init([])
from solver.contact_law import ContactModel
from solver.model import dynmat
from solver.references import dense_eigenvalues
from solver.model import operators
from solver.spectrum import counting
with open(sys.argv[1], "rb") as stream:
    p, large = pickle.load(stream)
dm = dynmat.assemble(p, ContactModel(0.5, rho_roll=0.3, rho_twist=0.2), PETSc.COMM_WORLD)
datasets, _, settings = counting.solve(dm, bin_width=0.2, zero_tol=1e-4)
lam = dense_eigenvalues(dm)
big = dynmat.assemble(large, ContactModel(1.0), PETSc.COMM_WORLD)
counts, large = counting.counts_below(operators.scaled_operator(big), np.array([0.5, 2.0, 8.0]), PETSc.COMM_WORLD.tompi4py())
print(json.dumps({"counts": datasets["counts"].tolist(), "build": settings["inertia"]["mumps_build"],
                  "dense": np.histogram(np.sqrt(lam[np.abs(lam) >= 1e-8]), datasets["edges"])[0].tolist(),
                  "large_counts": [int(c) for c in counts], "large_ordering": large["mumps_ordering_infog7"]}))
"""


@pytest.mark.serial_only  # starts processes of its own
def test_both_mumps_builds_count_like_dense(tmp_path):
    """Debian's PT-Scotch build of MUMPS (the default) and Debian's own build (ROTSOUND_MUMPS=debian)
    count the same integers as the dense histogram (128 spheres with rolling and twisting), and the
    same at three shifts of 4096 disks (12,288 DOF), which MUMPS orders with SCOTCH (INFOG 7 = 3)
    in the first and PORD (4) in the second; another ROTSOUND_MUMPS is one clear error."""
    import json
    import subprocess
    import sys

    runs = {}
    packings = _pickled(tmp_path / "packings.pickle", jammed_packing(128, 0.7, 5, dim=3),
                        jammed_packing(4096, 0.9, 5))
    for build in ("ptscotch", "debian"):
        done = subprocess.run([sys.executable, "-c", BUILD, packings], capture_output=True, text=True, timeout=180,
                              env={**child_env(), "ROTSOUND_MUMPS": build})
        assert done.returncode == 0, done.stderr[-3000:]
        runs[build] = json.loads(done.stdout.strip().splitlines()[-1])
    assert (runs["ptscotch"]["build"], runs["ptscotch"]["large_ordering"]) == ("ptscotch", 3), runs["ptscotch"]
    assert (runs["debian"]["build"], runs["debian"]["large_ordering"]) == ("debian", 4), runs["debian"]
    assert runs["ptscotch"]["counts"] == runs["debian"]["counts"] == runs["debian"]["dense"], runs
    assert runs["ptscotch"]["large_counts"] == runs["debian"]["large_counts"], runs
    assert len(set(runs["debian"]["large_counts"])) == 3, runs  # the shifts tell the counts apart
    bad = subprocess.run([sys.executable, "-m", "solver", "--version"], capture_output=True, text=True, timeout=60,
                         env={**child_env(), "ROTSOUND_MUMPS": "scotch"})
    assert bad.returncode != 0 and "ROTSOUND_MUMPS = 'scotch': allowed are 'ptscotch'" in bad.stderr, bad


def test_a_unit_counted_with_one_layout_is_reused_with_another(shared_tmp, monkeypatch, small_packing):
    """factor_ranks is left out of the unit keys and the scene digest: the run resumes from the
    units of a run with another layout, without counting again."""
    path = shared_tmp / "layout.h5"
    scenes = {ranks: scene_of(path, cache="off", seed=4, packing={"n": 64, "phi": 0.9}, model={"rho": [1.0]},
                              spectrum={"method": "counting", "factor_ranks": ranks}) for ranks in (1, 2)}
    assert scenes[1].digest() == scenes[2].digest()
    keys = {ranks: unit_keys.scene_keys(scene, [small_packing], []) for ranks, scene in scenes.items()}
    assert keys[1] == keys[2] and keys[1]
    first = pipeline.run(scenes[1], COMM, [])
    if COMM.rank == 0:
        path.unlink()  # the units folder stays: the next run resumes from it
    COMM.Barrier()

    def refuse(*args, **kwargs):
        raise AssertionError("counted again")
    monkeypatch.setattr(counting, "solve", refuse)
    again = pipeline.run(scenes[COMM.size], COMM, [])
    name = "spectra/r00_p0000"
    assert_all(np.array_equal(first["units"][name][0]["counts"], again["units"][name][0]["counts"]), name)


@pytest.mark.parametrize("memory_gib, shared", [(1e6, False), (1e-9, True)])
def test_auto_shares_the_factor_only_when_a_whole_one_does_not_fit(comm, small_packing, monkeypatch, memory_gib,
                                                                   shared):
    """factor_ranks auto: with ample memory a factor per rank; with none, one factor shared by all
    ranks (MUMPS's estimate against half the node's available memory per rank); the counts are the
    dense histogram's either way.  On one rank: 1, without an estimate."""
    monkeypatch.setattr(counting, "available_gib", lambda: memory_gib)
    dm = dynmat.assemble(small_packing, ContactModel(0.5), comm)
    try:
        datasets, _, settings = counting.solve(dm, bin_width=BIN, zero_tol=1e-4, factor_ranks="auto")
        lam = dense_eigenvalues(dm)
    finally:
        dm.destroy()
    expected, _ = np.histogram(np.sqrt(lam[np.abs(lam) >= 1e-8]), datasets["edges"])
    assert_all(np.array_equal(datasets["counts"], expected), "counts differ from eigvalsh")
    inertia = settings["inertia"]
    if COMM.size == 1:
        assert_all(inertia["factor_ranks"] == 1 and "factor_estimate_gib" not in inertia, str(inertia))
    else:
        assert_all(inertia["factor_ranks"] == (COMM.size if shared else 1), str(inertia))
        assert_all(0 < inertia["factor_estimate_gib"] < 0.1, str(inertia))  # 192 DOF: MB, not GB


def test_block_low_rank_counts_say_so_with_their_window(comm, small_packing):
    """MUMPS's BLR factorisation (ICNTL 35 = 1, CNTL 7 = eps), set by PETSc options and read back
    from the factor: counts_exact False and count_window = eps ||A||_inf; every bin that differs
    from the dense histogram has a mode within that window of one of its edges (in omega^2).
    Without BLR: counts_exact and a zero window.  At 64 disks MUMPS compresses no front (they are
    below its BLR block size), so the counts stay exact here even at eps = 0.3: the miscounts of
    real compression are measured on spheres in BENCHMARKS.md ("blr")."""
    from petsc4py import PETSc

    dm = dynmat.assemble(small_packing, ContactModel(0.5), comm)
    opts = PETSc.Options()
    try:
        lam = dense_eigenvalues(dm)
        _, exact_attrs, _ = counting.solve(dm, bin_width=BIN, zero_tol=1e-4)
        assert_all(exact_attrs["counts_exact"] is True and exact_attrs["blr_dropping"] == 0.0
                   and exact_attrs["count_window"] == 0.0, str(exact_attrs))
        A = operators.scaled_operator(dm)
        norm = A.norm(PETSc.NormType.INFINITY)
        A.destroy()
        for eps in (1e-10, 0.3):
            opts.setValue("inertia_mat_mumps_icntl_35", 1)
            opts.setValue("inertia_mat_mumps_cntl_7", eps)
            datasets, attrs, settings = counting.solve(dm, bin_width=BIN, zero_tol=1e-4)
            assert_all(settings["inertia"]["mumps_blr"] == {"icntl_35": 1, "cntl_7": eps}, str(settings["inertia"]))
            assert_all(attrs["counts_exact"] is False and attrs["blr_dropping"] == eps, str(attrs))
            assert_close(attrs["count_window"], eps * norm, rtol=1e-14, what="count_window = eps ||A||_inf")
            expected, _ = np.histogram(np.sqrt(lam[np.abs(lam) >= 1e-8]), datasets["edges"])
            for b in np.nonzero(datasets["counts"] != expected)[0]:
                near = [np.min(np.abs(lam - e**2)) <= attrs["count_window"] for e in datasets["edges"][b:b + 2]]
                assert_all(any(near), f"eps {eps}: bin {b} miscounted with no mode within the window of its edges")
    finally:
        opts.delValue("inertia_mat_mumps_icntl_35")
        opts.delValue("inertia_mat_mumps_cntl_7")
        dm.destroy()


@pytest.mark.parametrize("shared", [False, True])
def test_a_failed_factorisation_raises_instead_of_counting_zero(comm, shared):
    """A MUMPS factorisation that fails (here: error -19, its working memory capped at 1 MB per
    rank by ICNTL 23 through PETSc options) leaves PETSc's inertia at 0; counting must raise on
    every rank, naming the MUMPS error and its memory estimate, whether each rank factorises its
    own copy or all share one.  Matrix: the 5-point Laplacian of a 150 x 150 grid (22 500 rows,
    a factor of ~11 MB), rows split over ``comm``."""
    import scipy.sparse as sp
    from petsc4py import PETSc

    mpi, m = comm.tompi4py(), 150
    line = sp.diags([-np.ones(m - 1), 2 * np.ones(m), -np.ones(m - 1)], [-1, 0, 1])
    whole = (sp.kron(line, sp.eye(m)) + sp.kron(sp.eye(m), line)).tocsr()
    lo, hi = whole.shape[0] * comm.rank // comm.size, whole.shape[0] * (comm.rank + 1) // comm.size
    rows = whole[lo:hi]

    def laplacian():
        return PETSc.Mat().createAIJ(size=((hi - lo, None), (hi - lo, None)),
                                     csr=(rows.indptr, rows.indices, rows.data), comm=PETSc.Comm(comm))

    A = laplacian()
    opts = PETSc.Options()
    opts.setValue("inertia_mat_mumps_icntl_23", 1)
    try:
        with pytest.raises(RuntimeError, match=r"INFOG\(1\) = -19.*out of memory.*MB in all.*factor_ranks"):
            counting.counts_below(A, np.array([1.0, 2.0]), mpi, factor_ranks=comm.size if shared else 1)
    finally:
        opts.delValue("inertia_mat_mumps_icntl_23")
        A.destroy()
    A = laplacian()
    try:  # the same matrix, uncapped: the count is the exact one (2 - 2 cos terms below 1)
        theta = np.pi * np.arange(1, m + 1) / (m + 1)
        lam = (2 - 2 * np.cos(theta))[:, None] + (2 - 2 * np.cos(theta))[None, :]
        below, _ = counting.counts_below(A, np.array([1.0]), mpi, factor_ranks=comm.size if shared else 1)
        assert_all(int(below[0]) == int(np.sum(lam < 1.0)), f"{below} against {np.sum(lam < 1.0)}")
    finally:
        A.destroy()


@pytest.mark.parametrize("shared", [False, True])
def test_refactorisation_work_is_the_dense_ldlt_flop_count(comm, shared):
    """The work counts_below reports (``refactor_work``, the rate's numerator and denominator):
    on a dense symmetric positive definite matrix of order n = 400, whose LDL^T costs n^3/3 flops
    plus O(n^2) (MUMPS's RINFOG 3 then counts one front of n fully summed rows), every numeric
    refactorisation is counted once per group, whichever layout; the first count of each group (with
    the analysis) is not.  Rows split over ``comm``; the counts are the dense eigvalsh ones."""
    from petsc4py import PETSc

    mpi, n = comm.tompi4py(), 400
    root = np.random.default_rng(3).standard_normal((n, n))
    dense = root @ root.T / n
    lo, hi = n * mpi.rank // mpi.size, n * (mpi.rank + 1) // mpi.size
    A = PETSc.Mat().createAIJ(size=((hi - lo, None), (hi - lo, None)), nnz=(n, n), comm=comm)
    A.setValues(range(lo, hi), range(n), dense[lo:hi].ravel())
    A.assemble()
    lam = np.linalg.eigvalsh(dense)
    shifts = np.quantile(lam, [0.1, 0.3, 0.5, 0.7, 0.9])
    ranks = mpi.size if shared else 1
    try:
        below, settings = counting.counts_below(A, shifts, mpi, factor_ranks=ranks)
    finally:
        A.destroy()
    assert_all(list(below) == [int(np.sum(lam < s)) for s in shifts], f"{below}")
    refactorisations = shifts.size - mpi.size // ranks
    assert_all(settings["refactorisations"] == refactorisations, str(settings))
    assert_close(settings["refactor_flops"] / refactorisations, n**3 / 3, rtol=0.01, atol=0.0,
                 what="MUMPS flops per dense LDL^T (n^3/3 + O(n^2): 0.4 % at n = 400)")
    assert_all(settings["refactor_seconds"] > 0 and settings["refactor_cpu_seconds"] > 0, str(settings))
