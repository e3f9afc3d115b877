"""Poses and rotations.

Conventions (ARCHITECTURE.md): a :class:`Pose` is a position (x, y, z) in [m] and a unit
quaternion (x, y, z, w), as geometry_msgs. Roll, pitch, yaw are static x-y-z angles (tf's
convention): ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``. Code inside robocell works with 4×4
homogeneous matrices named for their frames (``T_world_tool``: the tool's pose in the world);
conversion happens once, at the boundary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import GeometryError, floats, number, vector

FloatArray = NDArray[np.float64]


def as_vector(value: ArrayLike, size: int, name: str) -> FloatArray:
    """``value`` as a finite float vector of ``size`` entries (flattened first), or a
    :class:`GeometryError`: :func:`robocell.errors.vector` for geometry."""
    return vector(floats(value, name, GeometryError).reshape(-1), size, name, GeometryError)


def normalize_quaternion(quat_xyzw: ArrayLike, name: str = "quaternion") -> FloatArray:
    """Unit quaternion (x, y, z, w) from any non-zero finite 4-vector."""
    q = as_vector(quat_xyzw, 4, name)
    norm = float(np.linalg.norm(q))
    if norm < 1e-9:
        raise GeometryError(f"{name} {q.tolist()} has zero length and cannot be normalized")
    return q / norm


def quat_to_matrix(quat_xyzw: ArrayLike) -> FloatArray:
    """3×3 rotation matrix of a quaternion (x, y, z, w); normalized first."""
    x, y, z, w = normalize_quaternion(quat_xyzw)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quat(R: ArrayLike) -> FloatArray:
    """Quaternion (x, y, z, w), w ≥ 0, of a 3×3 rotation matrix (Shepperd's method)."""
    # in Python floats: numpy's per-element indexing cost more than the arithmetic
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = np.asarray(R, dtype=float).tolist()
    trace = m00 + m11 + m22
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = [(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s]
    elif m00 > m11 and m00 > m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        q = [0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s]
    elif m11 > m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        q = [(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
        q = [(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s]
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    sign = -1.0 if q[3] < 0 else 1.0
    return np.array([sign * q[0] / n, sign * q[1] / n, sign * q[2] / n, sign * q[3] / n])


def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> FloatArray:
    """``Rz(yaw) @ Ry(pitch) @ Rx(roll)``, angles in [rad] (static x-y-z, as tf)."""
    roll, pitch, yaw = (
        number(a, n, GeometryError) for a, n in ((roll, "roll"), (pitch, "pitch"), (yaw, "yaw"))
    )
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_to_rpy(R: ArrayLike) -> FloatArray:
    """(roll, pitch, yaw) in [rad] with ``R = Rz(yaw) Ry(pitch) Rx(roll)``; pitch in [-π/2, π/2].

    At pitch = ±π/2 (gimbal lock) roll is set to 0 and yaw carries the whole rotation about z.
    """
    m = np.asarray(R, dtype=float)
    sp = -m[2, 0]
    pitch = math.asin(max(-1.0, min(1.0, sp)))
    if abs(sp) > 1.0 - 1e-9:
        roll = 0.0
        yaw = math.atan2(-m[0, 1], m[1, 1])
    else:
        roll = math.atan2(m[2, 1], m[2, 2])
        yaw = math.atan2(m[1, 0], m[0, 0])
    return np.array([roll, pitch, yaw])


def make_transform(R: ArrayLike | None = None, p: ArrayLike | None = None) -> FloatArray:
    """4×4 homogeneous transform from a rotation (default identity) and translation (default 0)."""
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if p is not None:
        T[:3, 3] = p
    return T


def invert_transform(T: ArrayLike) -> FloatArray:
    """Inverse of a rigid 4×4 transform (Rᵀ, −Rᵀp); no general matrix inverse."""
    T = np.asarray(T, dtype=float)
    inv = np.eye(4)
    inv[:3, :3] = T[:3, :3].T
    inv[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return inv


def rotation_error(R_a: ArrayLike, R_b: ArrayLike) -> float:
    """Angle in [rad] of the rotation that takes ``R_a`` to ``R_b``."""
    R = np.asarray(R_a).T @ np.asarray(R_b)
    # atan2(sin, cos) keeps precision at small angles, where acos(cos) loses half the digits
    s = 0.5 * math.sqrt(
        (R[2, 1] - R[1, 2]) ** 2 + (R[0, 2] - R[2, 0]) ** 2 + (R[1, 0] - R[0, 1]) ** 2
    )
    c = (np.trace(R) - 1.0) / 2.0
    return math.atan2(s, c)


@dataclass(frozen=True)
class Pose:
    """A rigid pose: ``position`` (x, y, z) in [m] and unit ``orientation`` (x, y, z, w).

    Build one with ``Pose(position, orientation)``, :meth:`from_rpy`, :meth:`from_matrix`; read it
    back with :meth:`matrix`, :meth:`rpy`. Poses compose like transforms: ``T_a_c = T_a_b * T_b_c``.
    """

    position: FloatArray
    orientation: FloatArray

    def __init__(
        self, position: ArrayLike = (0.0, 0.0, 0.0), orientation: ArrayLike = (0.0, 0.0, 0.0, 1.0)
    ) -> None:
        p = as_vector(position, 3, "position")
        q = normalize_quaternion(orientation, "orientation")
        p.flags.writeable = False
        q.flags.writeable = False
        object.__setattr__(self, "position", p)
        object.__setattr__(self, "orientation", q)

    @classmethod
    def _of(cls, position: FloatArray, orientation: FloatArray) -> Pose:
        """A pose of a finite position (3,) and a unit quaternion (4,) made here from valid
        input, without checking them again: grasp and place candidates make thousands of
        poses, and the checks were two thirds of a pose's 16 µs (measured)."""
        pose = object.__new__(cls)
        position.flags.writeable = False
        orientation.flags.writeable = False
        object.__setattr__(pose, "position", position)
        object.__setattr__(pose, "orientation", orientation)
        return pose

    @classmethod
    def _of_matrix(cls, T: FloatArray) -> Pose:
        """:meth:`from_matrix` of a 4×4 transform known finite and rigid."""
        return cls._of(T[:3, 3].copy(), matrix_to_quat(T[:3, :3]))

    @classmethod
    def from_rpy(
        cls, x: float, y: float, z: float, roll: float = 0.0, pitch: float = 0.0, yaw: float = 0.0
    ) -> Pose:
        """Pose from a position in [m] and roll, pitch, yaw in [rad] (static x-y-z)."""
        angles = as_vector((roll, pitch, yaw), 3, "roll, pitch, yaw")
        return cls((x, y, z), matrix_to_quat(rpy_to_matrix(*angles)))

    @classmethod
    def from_rpy_deg(
        cls, x: float, y: float, z: float, roll: float = 0.0, pitch: float = 0.0, yaw: float = 0.0
    ) -> Pose:
        """As :meth:`from_rpy` with the angles in degrees."""
        return cls.from_rpy(x, y, z, *np.radians(as_vector((roll, pitch, yaw), 3, "angles")))

    @classmethod
    def from_matrix(cls, T: ArrayLike) -> Pose:
        """Pose of a 4×4 homogeneous transform."""
        m = floats(T, "a transform", GeometryError)
        if m.shape != (4, 4) or not np.isfinite(m).all():
            raise GeometryError(f"a transform must be a finite 4x4 matrix, got shape {m.shape}")
        return cls._of_matrix(m)

    @classmethod
    def from_any(cls, value: Any) -> Pose:
        """A Pose from a Pose, a 4×4 matrix, ``[x, y, z]``, ``[x, y, z, qx, qy, qz, qw]``,
        ``[x, y, z, roll, pitch, yaw]`` (radians, as tf: moveit_commander's six-number form)
        or ``{"position": ..., "orientation": ...}`` (the forms cell files and MoveIt YAML
        use)."""
        if isinstance(value, Pose):
            return value
        if isinstance(value, dict):
            extra = set(value) - {"position", "orientation"}
            if extra:
                raise GeometryError(
                    f"unknown pose key(s) {sorted(extra)}; expected: position, orientation"
                )
            return cls(value.get("position", (0, 0, 0)), value.get("orientation", (0, 0, 0, 1)))
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            arr = np.empty(0)  # not numbers: the error below
        if arr.shape == (4, 4):
            return cls.from_matrix(arr)
        if arr.shape == (3,):
            return cls(arr)
        if arr.shape == (7,):
            return cls(arr[:3], arr[3:])
        if arr.shape == (6,):
            return cls.from_rpy(*(float(v) for v in arr))
        raise GeometryError(
            f"cannot read a pose from {value!r}; give a Pose, a 4x4 matrix, [x, y, z], "
            "[x, y, z, qx, qy, qz, qw], [x, y, z, roll, pitch, yaw] or {position, orientation}"
        )

    def matrix(self) -> FloatArray:
        """The 4×4 homogeneous transform (a new array each call)."""
        return self._transform().copy()

    def _transform(self) -> FloatArray:
        """The 4×4 homogeneous transform, computed once and shared: not to be changed."""
        T = self.__dict__.get("_matrix")
        if T is None:
            # the orientation is a unit quaternion already (checked when the pose was made)
            x, y, z, w = (float(v) for v in self.orientation)
            T = np.array(
                [
                    [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), 0.0],
                    [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w), 0.0],
                    [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y), 0.0],
                    [0.0, 0.0, 0.0, 1.0],
                ]
            )
            T[:3, 3] = self.position
            object.__setattr__(self, "_matrix", T)  # poses are immutable: computed once
        return T  # type: ignore[no-any-return]

    def rotation(self) -> FloatArray:
        """The 3×3 rotation matrix."""
        return self.matrix()[:3, :3]

    def rpy(self) -> FloatArray:
        """(roll, pitch, yaw) in [rad]."""
        return matrix_to_rpy(self.rotation())

    def rpy_deg(self) -> FloatArray:
        """(roll, pitch, yaw) in degrees."""
        return np.degrees(self.rpy())

    def inverse(self) -> Pose:
        return Pose._of_matrix(invert_transform(self._transform()))

    def __mul__(self, other: Pose) -> Pose:
        if not isinstance(other, Pose):
            return NotImplemented
        # the product of two poses is finite and rigid
        return Pose._of_matrix(self._transform() @ other._transform())

    def isclose(self, other: Pose, atol: float = 1e-9, rot_atol: float = 1e-9) -> bool:
        """Same position within ``atol`` [m] and orientation within ``rot_atol`` [rad]."""
        if not isinstance(other, Pose):
            raise GeometryError(f"isclose compares two Poses, got {type(other).__name__}")
        return bool(
            np.linalg.norm(self.position - other.position) <= atol
            and rotation_error(self.rotation(), other.rotation()) <= rot_atol
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Pose):
            return NotImplemented
        return bool(
            np.array_equal(self.position, other.position)
            and np.array_equal(self.orientation, other.orientation)
        )

    def __hash__(self) -> int:
        return hash((self.position.tobytes(), self.orientation.tobytes()))

    def __repr__(self) -> str:
        p = ", ".join(f"{v:.4g}" for v in self.position)
        q = ", ".join(f"{v:.4g}" for v in self.orientation)
        return f"Pose(position=({p}), orientation=({q}))"

    def to_dict(self) -> dict[str, list[float]]:
        """``{"position": [...], "orientation": [x, y, z, w]}`` as MoveIt YAML writes it."""
        return {"position": self.position.tolist(), "orientation": self.orientation.tolist()}
