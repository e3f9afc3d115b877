import math

import numpy as np
import pytest

from robocell.errors import GeometryError, RobocellError
from robocell.geometry import Pose, matrix_to_quat, matrix_to_rpy, quat_to_matrix, rpy_to_matrix


def test_rpy_is_static_xyz():
    # yaw 90°: x goes to y; pitch 90°: x goes to -z; R = Rz Ry Rx
    assert np.allclose(rpy_to_matrix(0, 0, math.pi / 2) @ [1, 0, 0], [0, 1, 0])
    assert np.allclose(rpy_to_matrix(0, math.pi / 2, 0) @ [1, 0, 0], [0, 0, -1])
    r, p, y = 0.3, -0.4, 1.2
    Rx = rpy_to_matrix(r, 0, 0)
    Ry = rpy_to_matrix(0, p, 0)
    Rz = rpy_to_matrix(0, 0, y)
    assert np.allclose(rpy_to_matrix(r, p, y), Rz @ Ry @ Rx)


def test_rpy_and_quaternion_round_trips():
    rng = np.random.default_rng(0)
    for _ in range(200):
        rpy = rng.uniform(
            [-math.pi, -math.pi / 2 + 1e-3, -math.pi], [math.pi, math.pi / 2 - 1e-3, math.pi]
        )
        R = rpy_to_matrix(*rpy)
        assert np.allclose(matrix_to_rpy(R), rpy, atol=1e-9)
        q = matrix_to_quat(R)
        assert abs(np.linalg.norm(q) - 1) < 1e-12 and q[3] >= 0
        assert np.allclose(quat_to_matrix(q), R, atol=1e-12)


def test_quaternion_near_half_turn():
    for axis in np.eye(3):
        R = 2 * np.outer(axis, axis) - np.eye(3)  # 180° about axis
        assert np.allclose(quat_to_matrix(matrix_to_quat(R)), R)


def test_pose_composition_and_inverse():
    a = Pose.from_rpy(0.1, 0.2, 0.3, 0.4, -0.5, 0.6)
    b = Pose.from_rpy_deg(-1, 2, 0.5, 10, 20, 30)
    assert (a * a.inverse()).isclose(Pose(), atol=1e-12, rot_atol=1e-9)
    assert np.allclose((a * b).matrix(), a.matrix() @ b.matrix())
    assert Pose.from_matrix(a.matrix()).isclose(a, 1e-12, 1e-9)
    assert np.allclose(b.rpy_deg(), [10, 20, 30])


def test_pose_normalizes_and_reads_forms():
    p = Pose((1, 2, 3), (0, 0, 2, 0))
    assert np.allclose(p.orientation, [0, 0, 1, 0])
    assert Pose.from_any([1, 2, 3]).isclose(Pose((1, 2, 3)))
    assert Pose.from_any({"position": [1, 0, 0], "orientation": [0, 0, 0, 1]}).isclose(
        Pose((1, 0, 0))
    )
    assert Pose.from_any([0, 0, 0, 0, 0, 0, 1]).isclose(Pose())


def test_six_numbers_are_a_position_and_roll_pitch_yaw_as_moveit_commander_reads_them():
    """[x, y, z, roll, pitch, yaw]: tf's static x-y-z angles, R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = 0.3, -0.5, 1.2
    c, s = math.cos, math.sin
    Rx = np.array([[1, 0, 0], [0, c(r), -s(r)], [0, s(r), c(r)]])
    Ry = np.array([[c(p), 0, s(p)], [0, 1, 0], [-s(p), 0, c(p)]])
    Rz = np.array([[c(y), -s(y), 0], [s(y), c(y), 0], [0, 0, 1]])
    pose = Pose.from_any([0.4, -0.1, 0.25, r, p, y])
    assert np.allclose(pose.position, [0.4, -0.1, 0.25])
    assert np.allclose(pose.rotation(), Rz @ Ry @ Rx, atol=1e-12)
    assert np.allclose(pose.rpy(), [r, p, y])
    with pytest.raises(GeometryError, match="roll, pitch, yaw"):
        Pose.from_any([0, 0, 0, math.nan, 0, 0])


@pytest.mark.parametrize(
    "position, orientation, words",
    [
        ((0, 0, math.nan), (0, 0, 0, 1), "NaN"),
        ((0, 0, 0), (0, 0, 0, 0), "zero length"),
        ((0, 0), (0, 0, 0, 1), "3 entries"),
        ((0, 0, 0), (0, 0, math.inf, 1), "NaN or infinite"),
    ],
)
def test_bad_poses_raise_clear_errors(position, orientation, words):
    with pytest.raises(GeometryError, match=words) as info:
        Pose(position, orientation)
    assert isinstance(info.value, RobocellError)


@pytest.mark.parametrize(
    "call",
    [
        lambda: rpy_to_matrix(math.inf, 0, 0),
        lambda: rpy_to_matrix("abc", 0, 0),
        lambda: Pose.from_rpy(0, 0, 0, None, 0, 0),
        lambda: Pose.from_matrix("abc"),
        lambda: Pose.from_any({"position": "abc"}),
        lambda: Pose.from_any("abc"),
        lambda: Pose().isclose([0, 0, 0]),
    ],
)
def test_values_of_the_wrong_kind_get_a_geometry_error(call):
    """Not a ValueError from math or a conversion, nor an AttributeError, from inside."""
    with pytest.raises(GeometryError):
        call()


def test_pose_is_immutable():
    p = Pose((1, 2, 3))
    with pytest.raises(ValueError):
        p.position[0] = 5.0
