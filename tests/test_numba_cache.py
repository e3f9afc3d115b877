"""robocell's kernels are cached under a stamp of all of their sources (robocell._numba_cache)."""

from __future__ import annotations

import re

from numba.core import caching

import robocell._numba_cache as NC
from robocell.planning import _kernels as PK
from robocell.scene import _kernels as SK


def test_every_module_with_compiled_code_is_in_the_digest() -> None:
    compiled = {
        str(p.relative_to(NC.PACKAGE))
        for p in NC.PACKAGE.rglob("*.py")
        if re.search(r"^\s*@(njit|numba\.njit|jit)\b", p.read_text(), re.M)
    }
    assert compiled == set(NC.KERNEL_SOURCES)


def test_a_kernel_is_stamped_with_the_digest_of_every_kernel_source() -> None:
    # the planner's searches inline the collision kernel's state check: their cache entry
    # must change when the state check's module does, not only when their own does
    for kernel in (PK.plan_in, SK.scan):
        impl = kernel._cache._impl
        assert isinstance(impl.locator, NC._InTree | NC._UserProvided | NC._UserWide)
        assert impl.locator.get_source_stamp() == NC.sources_digest()


def test_the_digest_follows_each_source(tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    for name in NC.KERNEL_SOURCES:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes((NC.PACKAGE / name).read_bytes())
    monkeypatch.setattr(NC, "PACKAGE", tmp_path)
    NC.sources_digest.cache_clear()
    try:
        first = NC.sources_digest()
        assert first == NC.sources_digest.__wrapped__()
        with open(tmp_path / "scene/_kernels.py", "a") as f:
            f.write("\n# changed\n")
        NC.sources_digest.cache_clear()
        assert NC.sources_digest() != first
    finally:
        NC.sources_digest.cache_clear()


def test_other_packages_keep_numbas_locators() -> None:
    assert NC.locator_classes()[:3] == [NC._UserProvided, NC._InTree, NC._UserWide]
    assert NC._InTree.from_function(caching.__loader__, caching.__file__) is None
