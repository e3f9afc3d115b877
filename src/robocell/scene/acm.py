"""The allowed-collision matrix (MoveIt's AllowedCollisionMatrix)."""

from __future__ import annotations

from collections.abc import Iterable

from robocell.errors import SceneError


class AllowedCollisionMatrix:
    """Which pairs of names (links, object ids) may touch.

    An explicit entry for a pair wins; otherwise a name's default entry (allowed with everything)
    applies; otherwise the pair is checked. Seeded from the SRDF's disabled collisions.
    """

    def __init__(self, allowed_pairs: Iterable[Iterable[str]] = ()) -> None:
        self._entries: dict[frozenset[str], bool] = {}
        self._defaults: dict[str, bool] = {}
        self.version = 0  # bumped on every change: checkers built from an older one are stale
        for pair in allowed_pairs:
            a, b = tuple(pair)
            self.set_entry(a, b, True)

    def set_entry(self, a: str, b: str | Iterable[str], allowed: bool) -> None:
        """Allow (True) or forbid (False) contact between ``a`` and ``b`` (one name or several)."""
        others = [b] if isinstance(b, str) else list(b)
        for o in others:
            if o == a:
                raise SceneError(f"an allowed-collision entry needs two different names, got {a!r}")
            self._entries[frozenset((a, o))] = bool(allowed)
        self.version += 1

    def set_default(self, name: str, allowed: bool) -> None:
        """Allow or forbid contact between ``name`` and everything without an explicit entry."""
        self._defaults[name] = bool(allowed)
        self.version += 1

    def remove(self, name: str) -> None:
        """Forget every entry that names ``name`` (when an object leaves the scene)."""
        self._entries = {k: v for k, v in self._entries.items() if name not in k}
        self._defaults.pop(name, None)
        self.version += 1

    def allowed(self, a: str, b: str) -> bool:
        entry = self._entries.get(frozenset((a, b)))
        if entry is not None:
            return entry
        return self._defaults.get(a, False) or self._defaults.get(b, False)

    def entries(self) -> dict[frozenset[str], bool]:
        return dict(self._entries)

    def names(self) -> set[str]:
        out: set[str] = set(self._defaults)
        for k in self._entries:
            out |= k
        return out

    def copy(self) -> AllowedCollisionMatrix:
        acm = AllowedCollisionMatrix()
        acm._entries = dict(self._entries)
        acm._defaults = dict(self._defaults)
        return acm

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, AllowedCollisionMatrix):
            return NotImplemented
        return self._entries == other._entries and self._defaults == other._defaults
