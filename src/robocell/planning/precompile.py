"""A first run's compiling on both cores: the planning kernels in a second process while the
first compiles the collision kernels and loads the cell.

numba compiles in the process that calls a kernel, holding the GIL, one kernel after the
other: a first run with an empty cache spent 110 of its 200 s on the planning kernels (the
searches, the shortcut, the detour, the final check) after the 90 s of the collision kernels.
The searches and the shortcut compile just as well in a second process, which leaves them in
numba's cache on disk; :func:`robocell.planning.rrt.warm_up` compiles the rest meanwhile, then
waits for it and loads them from there.

``python -m robocell.planning.precompile`` is that second process: it builds a checker of the
sorting cell's arm (its kernels' types are those of every checker) without compiling the
collision kernels, and compiles the searches and the shortcut.
"""

from __future__ import annotations

import atexit
import os
import subprocess
import sys
import time

# the process running, if any: started by :func:`start`, waited for by :func:`wait`
_JOB: list[subprocess.Popen[bytes]] = []


def kernels_cached() -> bool:
    """Whether the planning kernels are in numba's cache already, for these sources (then
    nothing is started): plan_in's index, the largest of them, as numba itself reads it
    (wherever its locator keeps it), fresh for its stamp, the digest of robocell's kernel
    sources (:mod:`robocell._numba_cache`). An index left by other sources (an older install)
    is not: its kernels compile again."""
    from robocell.planning import _kernels as PK

    try:
        return bool(PK.plan_in._cache._cache_file._load_index())  # type: ignore[attr-defined]
    except Exception:  # unreadable: as if absent
        return False


def start() -> bool:
    """Start compiling the planning kernels in a second process unless they are cached; True
    if it started. Nothing else changes: a process that fails or is slow costs nothing but
    the time :func:`wait` gives it."""
    if _JOB or kernels_cached():
        return False
    try:
        _JOB.append(
            subprocess.Popen(
                [sys.executable, "-m", "robocell.planning.precompile"],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                env=dict(os.environ),
            )
        )
    except OSError:
        return False
    atexit.register(_stop)  # not left compiling when this process ends first (Ctrl-C)
    return True


def _stop() -> None:
    for job in _JOB:
        if job.poll() is None:
            job.kill()


def wait(timeout: float = 600.0) -> None:
    """Wait for the second process, if one runs (at most ``timeout`` [s]; what it has not
    compiled by then compiles here, as without it)."""
    if not _JOB:
        return
    job = _JOB.pop()
    try:
        job.wait(timeout)
    except subprocess.TimeoutExpired:
        job.kill()


def main() -> int:
    from robocell.cell import Cell
    from robocell.planning.rrt import warm_up
    from robocell.scene import checker as CK

    t0 = time.perf_counter()
    CK.skip_warm_up()  # the first process compiles the collision kernels
    cell = Cell.load("sorting", mode="kinematic", time_scale=0)
    warm_up(cell.scene.checker("arm"), searches_only=True)
    print(f"planning kernels compiled in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
