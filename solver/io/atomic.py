"""Files that appear whole or not at all: written under a temporary name next to the target,
then renamed over it (atomic on POSIX), so that a process killed mid-write leaves the old file
or none, never a damaged one.  Not collective (the caller decides which rank writes).
"""

from __future__ import annotations

import contextlib
import os


@contextlib.contextmanager
def atomic_write(path: str):
    """Yield ``path + '.partial'`` to write; rename it to ``path`` when the block ends normally,
    remove it and re-raise when the block raises (anything, KeyboardInterrupt included).  A
    stale ``.partial`` from a killed writer is removed first."""
    partial = path + ".partial"
    if os.path.lexists(partial):
        os.remove(partial)
    try:
        yield partial
        os.replace(partial, path)
    except BaseException:
        if os.path.lexists(partial):
            os.remove(partial)
        raise
