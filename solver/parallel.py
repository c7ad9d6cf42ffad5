"""MPI helpers: agree-then-raise, owner-computes-then-broadcast, block ownership.

All functions take ``comm`` (an ``mpi4py.MPI.Comm``) explicitly and are collective on it.
"""

from __future__ import annotations

import pickle
from typing import Any, Callable, Sequence

import numpy as np


def _portable(error: BaseException | None) -> BaseException | None:
    """``error``, or a RuntimeError naming its type and message if it cannot be pickled and
    unpickled (an exception holding a lock or a file, or with a custom constructor): the
    exchange in :func:`agree` must never fail on one rank only."""
    try:
        pickle.loads(pickle.dumps(error))
        return error
    except Exception:  # noqa: BLE001 - whatever pickling raises, send a plain copy instead
        return RuntimeError(f"{type(error).__name__}: {error}")


def agree(comm, error: BaseException | None) -> None:
    """Raise on every rank if any rank had an error. Collective.

    The lowest failing rank's exception is raised everywhere (the same object on that rank,
    with its traceback; an unpickled copy, same type and message, elsewhere).
    """
    errors = comm.allgather(_portable(error))
    first = next((rank for rank, err in enumerate(errors) if err is not None), None)
    if first is not None:
        raise error if first == comm.rank else errors[first]


def owner_compute(comm, tasks: Sequence[Any], func: Callable[[Any], Any]) -> list[Any]:
    """Run ``func(task)`` for each task on rank ``index % size``; everybody gets all results.

    Collective.  Results do not depend on the number of ranks as long as ``func`` is
    deterministic in its task.  An exception on any rank is re-raised on every rank.
    Decision: that includes BaseExceptions (KeyboardInterrupt, SystemExit, ...): let through on
    their own rank only, they would leave the other ranks waiting in the next collective for a
    rank that is gone; so they too are caught and raised on every rank (a Ctrl-C or a sys.exit
    inside ``func`` stops every rank).
    """
    size, rank = comm.size, comm.rank
    mine: dict[int, Any] = {}
    error: BaseException | None = None
    for index in range(rank, len(tasks), size):
        try:
            mine[index] = func(tasks[index])
        except BaseException as exc:  # noqa: BLE001 - re-raised on all ranks below (docstring)
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
