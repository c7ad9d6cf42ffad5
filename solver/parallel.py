"""MPI helpers: agree-then-raise, owner-computes-then-broadcast, block ownership.

All functions take ``comm`` (an ``mpi4py.MPI.Comm``) explicitly and are collective on it.
"""

from __future__ import annotations

import pickle
from typing import Any, Callable, Sequence

import numpy as np

from .wording import counted


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


def on_every_rank(comm, work: Callable[[], Any]) -> Any:
    """``work()`` on every rank (a rank's own file, say), its result returned; an error on any
    rank raised on every rank, of any type as in :func:`owner_compute`, before anyone goes on to a
    collective that the failed rank would miss.  Collective."""
    result, error = None, None
    try:
        result = work()
    except BaseException as exc:  # noqa: BLE001 - re-raised on all ranks below
        error = exc
    agree(comm, error)
    return result


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


class Groups:
    """The ranks of ``comm`` in groups of ``size`` consecutive ranks (default: one group of all),
    each group with its own sub-communicator ``local``, and independent tasks dealt to them.

    Tasks are dealt in a snake: task t of a list goes to group t % count on even laps of
    ``count`` tasks and to group count - 1 - t % count on odd ones (0, 1, 1, 0, 0, 1, ... for two
    groups).  The caller orders the list by decreasing expected cost without regard to the
    grouping, so that each lap's most costly task goes to the group whose share is the lightest
    so far, and a task's result depends on the grouping only through the size of the
    communicator it is solved on.  A ``local`` of several groups is named
    ``group <g>/<count>`` (MPI's communicator name, read back by :func:`label`).  Collective on
    ``comm`` (making and freeing; use it as a context manager).
    """

    def __init__(self, comm, size: int | None = None):
        size = comm.size if size is None else size
        if size < 1 or comm.size % size:
            raise ValueError(f"group size {size} does not divide {counted(comm.size, 'rank')}")
        self.comm, self.size, self.count = comm, size, comm.size // size
        self.index = comm.rank // size
        self.local = comm if self.count == 1 else comm.Split(self.index, comm.rank)
        if self.count > 1:
            self.local.Set_name(f"group {self.index + 1}/{self.count}")

    def __enter__(self) -> Groups:
        return self

    def __exit__(self, *exc) -> None:
        if self.local is not self.comm:
            self.local.Free()

    def owner(self, task: int) -> int:
        """The group that solves task number ``task`` (the snake deal). Not collective."""
        lap, place = divmod(task, self.count)
        return place if lap % 2 == 0 else self.count - 1 - place

    def mine(self, tasks: Sequence[Any]) -> list[Any]:
        """The tasks of this rank's group, in their order. Not collective."""
        return [task for t, task in enumerate(tasks) if self.owner(t) == self.index]

    def wait(self, poll: float = 0.01) -> None:
        """Barrier on ``comm`` that sleeps instead of spinning while the other groups finish their
        tasks (a waiting rank would otherwise take a core from a working one). Collective."""
        import time

        request = self.comm.Ibarrier()
        while not request.Test():
            time.sleep(poll)

    def share(self, results: dict[str, Any], owners: dict[str, int]) -> dict[str, Any]:
        """Every group's ``results`` on every rank: ``owners`` maps each name to the group that
        holds it (in ``results`` on all of that group's ranks); one broadcast per name from that
        group's first rank, in ``owners``' order.  Collective on ``comm``."""
        if self.count == 1:
            return dict(results)
        return {name: self.comm.bcast(results.get(name) if group == self.index else None, root=group * self.size)
                for name, group in owners.items()}


def label(comm) -> str:
    """'[group g/count] ' for the sub-communicator of one of several :class:`Groups`, else ''
    (a prefix for progress lines). Not collective."""
    name = comm.Get_name()
    return f"[{name}] " if name.startswith("group ") else ""
