"""MPI helpers: agree-then-raise, owner-computes-then-broadcast, block ownership.

All functions take ``comm`` (an ``mpi4py.MPI.Comm``) explicitly and are collective on it.
"""

from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np


def agree(comm, error: BaseException | None) -> None:
    """Raise on every rank if any rank had an error. Collective.

    The first failing rank's exception object is re-raised (same type and message).
    """
    errors = comm.allgather(error)
    for err in errors:
        if err is not None:
            raise err


def owner_compute(comm, tasks: Sequence[Any], func: Callable[[Any], Any]) -> list[Any]:
    """Run ``func(task)`` for each task on rank ``index % size``; everybody gets all results.

    Collective.  Results do not depend on the number of ranks as long as ``func`` is
    deterministic in its task.  An exception on any rank is re-raised on every rank.
    """
    size, rank = comm.size, comm.rank
    mine: dict[int, Any] = {}
    error: BaseException | None = None
    for index in range(rank, len(tasks), size):
        try:
            mine[index] = func(tasks[index])
        except Exception as exc:  # noqa: BLE001 - re-raised on all ranks below
            error = exc
            break
    agree(comm, error)
    results: list[Any] = [None] * len(tasks)
    for index in range(len(tasks)):
        results[index] = comm.bcast(mine.get(index), root=index % size)
    return results


def block_range(n: int, comm) -> tuple[int, int]:
    """Contiguous ``[start, stop)`` of ``n`` items owned by this rank (first ranks get one more).

    Not collective.
    """
    size, rank = comm.size, comm.rank
    base, extra = divmod(n, size)
    start = rank * base + min(rank, extra)
    return start, start + base + (1 if rank < extra else 0)


def global_max(comm, value: float) -> float:
    """Maximum of ``value`` over ranks. Collective."""
    from mpi4py import MPI

    return comm.allreduce(value, op=MPI.MAX)


def seed_sequence(seed: int, index: int) -> np.random.SeedSequence:
    """Seed sequence of configuration ``index`` of a scene seeded with ``seed`` (rank-free)."""
    return np.random.SeedSequence([int(seed), int(index)])
