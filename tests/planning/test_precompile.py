"""A first run's second process that compiles the planning kernels (planning.precompile)."""

import subprocess
import sys

from robocell.planning import precompile
from robocell.planning.rrt import warm_up


def test_the_second_process_compiles_into_the_cache_the_first_loads_from(walled):
    """Once the kernels are in numba's cache, nothing is started; the second process runs to
    its end (loading them from the cache here), and waiting for it leaves none running."""
    warm_up(walled.checker("arm"))  # compiled (or loaded) here, so cached on disk
    assert precompile.kernels_cached()
    assert not precompile.start()
    done = subprocess.run(
        [sys.executable, "-m", "robocell.planning.precompile"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "planning kernels compiled" in done.stdout


def test_an_index_of_other_sources_is_not_cached(walled, monkeypatch):
    """An index left by other kernel sources (an older install) does not count: numba would
    compile its kernels again, so the second process is worth starting."""
    from robocell.planning import _kernels as PK

    warm_up(walled.checker("arm"))
    assert precompile.kernels_cached()
    monkeypatch.setattr(PK.plan_in._cache._cache_file, "_source_stamp", b"other sources")
    assert not precompile.kernels_cached()


def test_start_and_wait(monkeypatch):
    """Without the kernels cached, start() runs the second process once; wait() joins it."""
    monkeypatch.setattr(precompile, "kernels_cached", lambda: False)
    assert precompile.start()
    assert not precompile.start()  # one at a time
    job = precompile._JOB[0]
    precompile.wait()
    assert not precompile._JOB
    assert job.returncode == 0
    precompile.wait()  # nothing to wait for
