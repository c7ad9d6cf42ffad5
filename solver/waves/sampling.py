"""What a standing-wave run records: the sampled Fourier components and the energy.

For R waves (excited component c_r, axis a_r, wave number k_r; see ``excitation``), every
``sample_every`` steps:
    z_r(t)       = sum_i p . v_i(t) exp(-i k . (r_i(0) + u_i(t)))   (the paper's definition,
                                                                      r_i(t) = r_i(0) + u_i(t))
    z_fixed_r(t) = sum_i p . v_i(t) exp(-i k . r_i(0))              (exactly linear: the form the
                                                                      spectral path and the exact
                                                                      reference use)
with the run's polarisation p and wave vector k (``excitation.polarisation``: p = e_c and
k = k e_a in an orthogonal cell, where p . v_i = v_i,c and k . u_i = k u_i,a)
    E_r(t)       = v^T M v / 2 + u^T D u / 2                         (conserved by eq:motion)
``FourierSampler`` computes them (one reduction for all R waves), the same for both TS paths
(block Verlet and PETSc TS types); ``Recorder`` keeps them and stops the TS when the energy stops
being finite or grows tenfold.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .excitation import k_vector, phases, polarisation


@dataclass
class WaveSeries:
    """Samples of one run: t (S,), z and z_fixed (S,) complex, energy (S,); steps taken (time
    steps, or Lanczos steps for the spectral path), for the spectral path its error estimate, and
    what the solver used (``settings``: read back from the TS, or the Lanczos parameters); a
    LAMMPS run's contact series (``lammps_dem.Contacts.as_datasets``: name -> (S,)), else None."""

    t: np.ndarray
    z: np.ndarray
    z_fixed: np.ndarray
    energy: np.ndarray
    steps: int
    error_estimate: float = float("nan")
    settings: dict | None = None
    contacts: dict | None = None


class FourierSampler:
    """z, z_fixed and E (each (R,)) of R waves from this rank's u, v and D u, each (nloc, R).

    ``waves``: [(excited component, axis of k, k)], k a float along the axis or the (D,) wave
    vector (``excitation.wave_vector``); ``comm``: mpi4py communicator of ``dm``.
    Calls are collective (one allreduce).
    """

    def __init__(self, dm, positions, waves: list[tuple[int, int, object]], comm):
        self.comm, self.dof = comm, dm.dof
        # p . v and k . u as sums over the slots where p (and k) are not zero, padded with weight 0:
        # (G, R) slot indices and weights (G = 1, weight 1 or k, with k along an axis)
        self.comp, self.coef = _gathered([polarisation(c, a, k, dm.dim, dm.dof) for c, a, k in waves])
        self.axis, self.ks = _gathered([k_vector(k, a, dm.dim) for _, a, k in waves])
        self.mass = dm.M.getArray().copy()[:, None]
        start, stop = dm.disk_range
        self.disks, self.cols = np.arange(stop - start)[:, None], np.arange(len(waves))[None, :]
        # exp(-i k . r_i(0)) per disk and wave: the conjugate of the channel's phase (``excitation.channel``)
        r0 = positions[dm.order[start:stop]]
        self.weight = np.conj(np.stack([np.exp(1j * phases(r0, a, k)) for _, a, k in waves], axis=1))

    def __call__(self, u: np.ndarray, v: np.ndarray, du: np.ndarray):
        runs = self.weight.shape[1]
        v3, u3 = v.reshape(-1, self.dof, runs), u.reshape(-1, self.dof, runs)
        vel = sum(coef * v3[self.disks, comp, self.cols] for comp, coef in zip(self.comp[:, None], self.coef[:, None]))
        shift = sum(k * u3[self.disks, axis, self.cols] for axis, k in zip(self.axis[:, None], self.ks[:, None]))
        fixed = vel * self.weight
        local = np.stack((np.sum(fixed * np.exp(-1j * shift), axis=0), np.sum(fixed, axis=0),
                          0.5 * np.sum(self.mass * v * v + u * du, axis=0)))
        z, z_fixed, energy = self.comm.allreduce(local)
        return z, z_fixed, energy.real


def _gathered(vectors: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(index (G, R), value (G, R)) of the non-zero entries of R ``vectors``, G the most any has,
    padded with index 0 and value 0."""
    nonzero = [np.flatnonzero(vector) for vector in vectors]
    count = max(len(found) for found in nonzero)
    index, value = np.zeros((count, len(vectors)), dtype=int), np.zeros((count, len(vectors)))
    for r, (vector, found) in enumerate(zip(vectors, nonzero)):
        index[:len(found), r], value[:len(found), r] = found, vector[found]
    return index, value


class Recorder:
    """Samples of a TS run every ``every`` steps through ``sampler``; on blow-up (energy not
    finite, or above 10 E(0)) it stops the TS after this step and sets ``blown``, the same on
    every rank (the energies are global).  ``record`` is collective."""

    def __init__(self, sampler: FourierSampler, every: int):
        self.sampler, self.every = sampler, every
        self.t, self.z, self.zf, self.e = [], [], [], []
        self.blown = False

    def due(self, step: int) -> bool:
        return step % self.every == 0 and not self.blown

    def record(self, ts, step, t, u, v, du) -> None:
        z, zf, energy = self.sampler(u, v, du)
        self.t.append(t)
        self.z.append(z)
        self.zf.append(zf)
        self.e.append(energy)
        if not np.all(np.isfinite(energy)) or np.any(energy > 10.0 * self.e[0]):
            self.blown = True
            ts.setMaxSteps(step)  # TSSolve ends after this step (a reason set here is overwritten)

    def series(self, steps: int, settings: dict | None) -> list[WaveSeries]:
        """One WaveSeries per wave."""
        t, z, zf, e = np.array(self.t), np.array(self.z), np.array(self.zf), np.array(self.e)
        return [WaveSeries(t, z[:, r], zf[:, r], e[:, r], steps, settings=settings) for r in range(z.shape[1])]
