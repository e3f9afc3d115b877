"""numba's on-disk cache of robocell's kernels, kept true to all of their sources.

numba keys a cached kernel on its own source file alone (on its content in the numba of this
writing, on its time stamp in older ones). A kernel of one module that calls or inlines a
kernel of another keeps its compiled copy of that code when only the other module changes:
the planner's searches (``planning/_kernels.py``) inline the collision kernel's state check
(``scene/_kernels.py``), and after a change to the state check alone they went on running the
old one, loaded from the cache (session 41). An install upgraded over an older one, whose
cache files stay beside it, would do the same.

robocell's kernels are therefore cached under locators of their own, which stamp each of them
with one digest of every module that holds compiled code (:data:`KERNEL_SOURCES`): a change to
any of them compiles them all again, once. They are numba's own locators otherwise (the same
folders, in the same order).
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path
from typing import Any

from numba.core import caching

PACKAGE = Path(__file__).resolve().parent
# every module of the package with numba-compiled code (tests/test_numba_cache.py checks it)
KERNEL_SOURCES = (
    "kinematics/_kernels.py",
    "kinematics/analytic.py",
    "planning/_kernels.py",
    "scene/_kernels.py",
    "scene/_swept_kernels.py",
    "scene/pair_tables.py",
    "scene/spheres.py",
    "trajectory/_kernels.py",
)


@functools.cache
def sources_digest() -> bytes:
    """The digest of :data:`KERNEL_SOURCES`' contents, read once per process."""
    h = hashlib.sha256()
    for name in KERNEL_SOURCES:
        h.update(name.encode())
        h.update((PACKAGE / name).read_bytes())
    return h.digest()


def _ours(py_file: str) -> bool:
    try:
        return Path(py_file).resolve().parent.parent == PACKAGE
    except OSError:
        return False


class _WholeSources:
    """A locator of robocell's kernels: its stamp is :func:`sources_digest`."""

    @classmethod
    def from_function(cls, py_func: Any, py_file: str) -> Any:
        if not _ours(py_file):
            return None
        return super().from_function(py_func, py_file)  # type: ignore[misc]

    def get_source_stamp(self) -> Any:
        return sources_digest()


class _UserProvided(_WholeSources, caching.UserProvidedCacheLocator):  # NUMBA_CACHE_DIR
    pass


class _InTree(_WholeSources, caching.InTreeCacheLocator):  # __pycache__ beside the module
    pass


class _UserWide(_WholeSources, caching.UserWideCacheLocator):  # the user's cache folder
    pass


def locator_classes() -> list[Any]:
    """numba's list of cache locators, tried in order (``_CacheImpl``'s in older numba)."""
    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # type: ignore[attr-defined]
    return impl._locator_classes  # type: ignore[no-any-return]


def install() -> None:
    """Put robocell's locators first (before any kernel of the package is decorated: numba
    picks a kernel's locator then). Idempotent."""
    classes = locator_classes()
    if _InTree not in classes:
        classes[:0] = [_UserProvided, _InTree, _UserWide]


install()  # robocell/__init__.py imports this module before any other of the package
