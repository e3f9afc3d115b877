"""The one error hierarchy of robocell.

Every error a user can reach is a :class:`RobocellError`. Messages name what was wrong and list
the valid choices, so that a typo is fixed from the message alone.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray


class RobocellError(Exception):
    """Root of every error robocell raises on purpose."""


class RobocellWarning(UserWarning):
    """Something robocell did in the user's place that they may want to do themselves (a
    default where the robot's description gives no value)."""


class GeometryError(RobocellError, ValueError):
    """A pose, rotation or shape is malformed (NaN, zero quaternion, non-positive size)."""


class ModelError(RobocellError):
    """A robot description (URDF, SRDF, joint limits) is malformed or names something unknown."""


class IKError(RobocellError):
    """Inverse kinematics was asked something it cannot answer (not 'no solution': that is a
    result, see :class:`robocell.kinematics.IKResult`)."""


class SceneError(RobocellError):
    """A planning-scene operation names an unknown or duplicate object, or bad geometry."""


class PlanningError(RobocellError):
    """A motion-planning request is malformed."""


class ExecutionError(RobocellError):
    """A trajectory cannot be executed."""


class CellError(RobocellError):
    """A cell file is malformed (unknown key, missing field, bad value, unknown robot or mesh)."""


class SimulationError(RobocellError):
    """The physics world diverged or was asked something it cannot do."""


class GraspError(RobocellError):
    """A grasp or place request is malformed."""


class ExerciseError(RobocellError):
    """A user's exercise file cannot be run (missing, not Python, nothing to run)."""


def choices(names: Iterable[str], limit: int = 30) -> str:
    """Format valid choices for an error message: ``'a, b, c'`` (sorted, at most ``limit``)."""
    items = sorted(names)
    if not items:
        return "(none)"
    shown = ", ".join(items[:limit])
    return shown if len(items) <= limit else f"{shown}, … ({len(items)} in all)"


def unknown(kind: str, name: object, known: Iterable[str]) -> str:
    """The standard message for an unknown name: ``unknown link 'x'; known: a, b``."""
    return f"unknown {kind} {name!r}; known: {choices(known)}"


def number(value: object, what: str, error: type[RobocellError]) -> float:
    """``value`` as a float when it is one finite real number (a Python or numpy number, not
    a bool or a string), else ``error`` naming ``what``: a user's ``"0.5"`` or ``None`` gets
    this message, not a TypeError from a comparison deep inside."""
    if type(value) is float or type(value) is int:
        # the ABC check below took half of a request's checks: 27 against 15 µs at a plan's
        # start, after other work (session 25)
        x = float(value)
    elif isinstance(value, numbers.Real) and not isinstance(value, bool):
        x = float(value)
    elif isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "fiu":
        x = float(value)
    else:
        raise error(f"{what} must be a number, got {value!r}")
    if not math.isfinite(x):
        raise error(f"{what} must be finite, got {value!r}")
    return x


def whole(value: object, what: str, error: type[RobocellError]) -> int:
    """``value`` as an int when it is a finite number with no fraction (2.0 is 2, 2.5 is
    refused rather than cut to 2), else ``error`` naming ``what``."""
    x = number(value, what, error)
    if x != int(x):
        raise error(f"{what} must be a whole number, got {value!r}")
    return int(x)


def floats(value: object, what: str, error: type[RobocellError]) -> NDArray[np.float64]:
    """``value`` as a float array (any shape; the caller checks it), else ``error`` naming
    ``what``: text, None or a ragged list."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise error(f"{what} must be numbers, got {value!r}") from exc


def vector(value: object, size: int, what: str, error: type[RobocellError]) -> NDArray[np.float64]:
    """``value`` as a (size,) float array of finite numbers, else ``error`` naming ``what``."""
    arr = floats(value, what, error)
    if arr.shape != (size,):
        raise error(f"{what} must have {size} entries, got shape {arr.shape}: {value!r}")
    if not np.all(np.isfinite(arr)):
        raise error(
            f"{what} must be {size} finite numbers, has a NaN or infinite entry: {arr.tolist()}"
        )
    return arr


def name_or(name: str | None, default: str) -> str:
    """``name``, or ``default`` for None or "" (MoveIt's "use the default" arguments). Not
    ``name or default``: an array's truth value raises. Whatever else a user passes comes
    back as it is, for the lookup that follows to refuse with the known names."""
    return default if name is None or (isinstance(name, str) and not name) else name
