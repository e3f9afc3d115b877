"""The message types of the exercise API, shaped like ROS's geometry_msgs so that the seed's user
code reads as written: ``pose.position.x``, ``pose.orientation.w``, ``place(..., position)``.

They are plain mutable records (a user may write ``p.z += 0.05``); each converts to and from
robocell's immutable :class:`~robocell.geometry.pose.Pose`, and a :class:`Point` also reads as a
3-vector (``np.asarray(point)``, ``x, y, z = point``).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robocell.errors import GeometryError
from robocell.geometry.pose import Pose


@dataclass
class Point:
    """A position [m] (geometry_msgs/Point)."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0

    def __iter__(self) -> Iterator[float]:
        return iter((self.x, self.y, self.z))

    def __array__(self, dtype: Any = None, copy: Any = None) -> NDArray[np.float64]:
        return np.array([self.x, self.y, self.z], dtype=dtype or float)

    @classmethod
    def of(cls, value: Any, what: str = "position") -> Point:
        """A Point from a Point (copied), a Pose message (its position) or three numbers."""
        if isinstance(value, PoseMsg):
            value = value.position
        try:
            v = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            v = np.zeros(0)
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise GeometryError(
                f"{what} must be a Point or three finite numbers (x, y, z), got {value!r}"
            )
        return cls(float(v[0]), float(v[1]), float(v[2]))


@dataclass
class Quaternion:
    """An orientation as a unit quaternion (x, y, z, w) (geometry_msgs/Quaternion)."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0

    def __iter__(self) -> Iterator[float]:
        return iter((self.x, self.y, self.z, self.w))


@dataclass
class PoseMsg:
    """A pose (geometry_msgs/Pose): ``position`` and ``orientation``."""

    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)

    def to_pose(self) -> Pose:
        """robocell's Pose of this message (raises GeometryError on NaN or a zero quaternion)."""
        return Pose(tuple(self.position), tuple(self.orientation))

    @classmethod
    def from_pose(cls, pose: Pose) -> PoseMsg:
        p, q = pose.position, pose.orientation
        return cls(Point(*map(float, p)), Quaternion(*map(float, q)))

    @classmethod
    def of(cls, value: Any) -> PoseMsg:
        """A Pose message from a Pose message (copied), a robocell Pose, or what
        :meth:`Pose.from_any` reads."""
        if isinstance(value, PoseMsg):
            return cls.from_pose(value.to_pose())
        return cls.from_pose(Pose.from_any(value))
