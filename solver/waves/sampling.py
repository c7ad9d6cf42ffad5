"""What a standing-wave run records: the sampled Fourier components and the energy.

For R waves (excited component c_r, axis a_r, wave number k_r; see ``excitation``), every
``sample_every`` steps:
    z_r(t)       = sum_i v_i,c(t) exp(-i k (r_i,a(0) + u_i,a(t)))   (the paper's definition,
                                                                      r_i(t) = r_i(0) + u_i(t))
    z_fixed_r(t) = sum_i v_i,c(t) exp(-i k r_i,a(0))                (exactly linear: the form the
                                                                      spectral path and the exact
                                                                      reference use)
    E_r(t)       = v^T M v / 2 + u^T D u / 2                         (conserved by eq:motion)
``FourierSampler`` computes them (one reduction for all R waves), the same for both TS paths
(block Verlet and PETSc TS types); ``Recorder`` keeps them and stops the TS when the energy stops
being finite or grows tenfold.  Units: d0 = m = kn = 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .excitation import channel


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

    ``waves``: [(excited component, axis of k, k)]; ``comm``: mpi4py communicator of ``dm``.
    Calls are collective (one allreduce).
    """

    def __init__(self, dm, positions, waves: list[tuple[int, int, float]], comm):
        self.comm, self.dof = comm, dm.dof
        self.comp = np.array([c for c, _, _ in waves])[None, :]
        self.axis = np.array([a for _, a, _ in waves])[None, :]
        self.ks = np.array([k for _, _, k in waves])[None, :]
        self.mass = dm.M.getArray().copy()[:, None]
        start, stop = dm.disk_range
        self.disks, self.cols = np.arange(stop - start)[:, None], np.arange(len(waves))[None, :]
        # exp(-i k r_i,a(0)) per disk and wave: the conjugate of the channel vector's entries
        self.weight = np.conj(np.stack([channel(dm, positions, c, a, k).reshape(-1, dm.dof)[:, c]
                                        for c, a, k in waves], axis=1))

    def __call__(self, u: np.ndarray, v: np.ndarray, du: np.ndarray):
        runs = self.weight.shape[1]
        vel = v.reshape(-1, self.dof, runs)[self.disks, self.comp, self.cols]
        shift = self.ks * u.reshape(-1, self.dof, runs)[self.disks, self.axis, self.cols]
        fixed = vel * self.weight
        local = np.stack((np.sum(fixed * np.exp(-1j * shift), axis=0), np.sum(fixed, axis=0),
                          0.5 * np.sum(self.mass * v * v + u * du, axis=0)))
        z, z_fixed, energy = self.comm.allreduce(local)
        return z, z_fixed, energy.real


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
