import numpy as np
import pinocchio as pin
import pytest

from robocell.errors import ModelError
from robocell.kinematics import _kernels as K
from robocell.kinematics import fk, fk_batch, jacobian, link_poses, link_poses_batch


def test_irb120_known_poses(irb120):
    arm = irb120.group("arm")
    T = fk(arm, np.zeros(6))
    assert np.allclose(T[:3, 3], [0.374, 0.0, 0.630]) and np.allclose(T[:3, :3], np.eye(3))
    # joint 1 at +90°: the tool swings to +y; joint 2 at +90°: the arm lies forward and down
    assert np.allclose(fk(arm, [np.pi / 2, 0, 0, 0, 0, 0])[:3, 3], [0, 0.374, 0.630])
    T2 = fk(arm, [0, np.pi / 2, 0, 0, 0, 0])
    assert np.allclose(T2[:3, 3], [0.27 + 0.07, 0, 0.29 - 0.374])


def test_ur5e_known_pose(ur5e):
    arm = ur5e.group("manipulator")
    # DH zero: the arm stretched along -x, tool offset by d4 (y) and down by d5 … d6
    T = fk(arm, np.zeros(6))
    assert np.allclose(T[:3, 3], [-0.425 - 0.3922, -0.1333 - 0.0996, 0.1625 - 0.0997])


@pytest.mark.parametrize(
    "robot_name, group",
    [
        ("irb120", "arm"),
        ("ur5e", "manipulator"),
        ("mbm_ur5", "manipulator"),
        ("mbm_panda", "panda_arm"),
    ],
)
def test_fk_matches_pinocchio(request, robot_name, group):
    robot = request.getfixturevalue(robot_name)
    g = robot.group(group)
    data = robot.pin_model.createData()
    rng = np.random.default_rng(3)
    for _ in range(20):
        full = robot.default_positions.copy()
        full[g.indices] = g.random(rng)
        ours = link_poses(robot, full)
        pin.framesForwardKinematics(robot.pin_model, data, robot.pin_configurations(full)[0])
        for name in robot.link_names:
            fid = robot.pin_model.getFrameId(name, pin.BODY)
            assert np.allclose(
                ours[robot.link_index(name)], data.oMf[fid].homogeneous, atol=1e-12
            ), name


def test_batch_equals_single(irb120):
    arm = irb120.group("arm")
    qs = arm.random(np.random.default_rng(0), 50)
    batch = fk_batch(arm, qs, "tcp")
    for q, T in zip(qs, batch, strict=True):
        assert np.allclose(fk(arm, q, "tcp"), T, atol=1e-14)
    full = np.tile(irb120.default_positions, (50, 1))
    full[:, arm.indices] = qs
    all_links = link_poses_batch(irb120, full)
    assert np.allclose(all_links[:, irb120.link_index("tcp")], batch)


@pytest.mark.parametrize(
    "robot_name, group, link",
    [
        ("irb120", "arm", "tcp"),
        ("ur5e", "manipulator", "tool0"),
        ("mbm_panda", "panda_arm", "panda_link8"),
        ("irb120", "arm_with_gripper", "gripper_left_finger"),
    ],
)
def test_jacobian_matches_finite_differences(request, robot_name, group, link):
    robot = request.getfixturevalue(robot_name)
    g = robot.group(group)
    rng = np.random.default_rng(5)
    h = 1e-7
    for _ in range(5):
        q = g.random(rng)
        J = jacobian(g, q, link)
        T0 = fk(g, q, link)
        for k in range(g.dof):
            dq = np.zeros(g.dof)
            dq[k] = h
            T1 = fk(g, q + dq, link)
            v = (T1[:3, 3] - T0[:3, 3]) / h
            dR = T1[:3, :3] @ T0[:3, :3].T
            w = np.array([dR[2, 1] - dR[1, 2], dR[0, 2] - dR[2, 0], dR[1, 0] - dR[0, 1]]) / (2 * h)
            assert np.allclose(J[:3, k], v, atol=1e-5)
            assert np.allclose(J[3:, k], w, atol=1e-5)


def test_sincos_polynomials_match_libm():
    # the block kinematics' sin and cos (fdlibm's polynomials after a two-part reduction)
    x = np.concatenate(
        [np.linspace(-20.0, 20.0, 400_001), np.pi / 4 * np.arange(-64, 65), [0.0, -0.0, 1e-300]]
    )
    sin_x, cos_x = np.empty_like(x), np.empty_like(x)
    K.sincos_block(x, sin_x, cos_x)
    assert np.abs(sin_x - np.sin(x)).max() <= 2.3e-16
    assert np.abs(cos_x - np.cos(x)).max() <= 2.3e-16
    # an angle beyond the polynomials' range (or NaN) sends its block to libm: the same values
    far = np.array([0.5, 3.0e5, -2.0, np.nan])
    K.sincos_block(far, sin_x[:4], cos_x[:4])
    assert np.array_equal(sin_x[:4], np.sin(far), equal_nan=True)
    assert np.array_equal(cos_x[:4], np.cos(far), equal_nan=True)


@pytest.mark.parametrize("robot_name", ["irb120", "ur5e", "mbm_ur5", "mbm_panda"])
def test_block_kinematics_equals_one_state_at_a_time(request, robot_name):
    # fk_block (a block of states joint by joint, as the collision kernel places bodies) gives
    # every link the pose fk_into gives it, for every group: revolute joints about any axis,
    # prismatic fingers, mimic joints, variables outside the group at their base values
    robot = request.getfixturevalue(robot_name)
    t = robot.tree
    arrays = (t.parent_link, t.child_link, t.origin, t.type, t.axis, t.var, t.mult, t.offset)
    joints = np.arange(len(t.parent_link), dtype=np.int64)
    root = robot.link_index(robot.root_link)
    rng = np.random.default_rng(11)
    base = robot.default_positions.copy()
    base += rng.uniform(-0.3, 0.3, base.shape)
    for name in robot.groups:
        g = robot.group(name)
        column = np.full(robot.n_variables, -1, np.int64)
        column[g.indices] = np.arange(g.dof)
        qs = np.vstack([g.random(rng, 20), rng.uniform(-40.0, 40.0, (5, g.dof))])
        Ts = np.full((t.n_links, 12, 16), np.nan)
        work = np.empty((3, 16))
        T = np.empty((t.n_links, 4, 4))
        for s0, n in [(0, 1), (1, 3), (4, 16), (20, 5)]:
            K.fk_block(qs, s0, n, column, base, joints, root, *arrays, Ts, *work)
            for s in range(n):
                full = base.copy()
                full[g.indices] = qs[s0 + s]
                K.fk_into(full, joints, root, *arrays, T)
                block = Ts[:, :, s].reshape(-1, 3, 4)
                assert np.allclose(block, T[:, :3, :], rtol=0, atol=1e-13), (name, s0 + s)


def test_relative_frames(irb120):
    arm = irb120.group("arm")
    q = [0.1, 0.2, -0.3, 0.4, 0.5, -0.6]
    T_tool0_tcp = fk(arm, q, "tcp", relative_to="tool0")
    assert np.allclose(T_tool0_tcp[:3, 3], [0.15, 0, 0]) and np.allclose(
        T_tool0_tcp[:3, :3], np.eye(3)
    )


def test_fk_rejects_bad_input(irb120):
    arm = irb120.group("arm")
    with pytest.raises(ModelError, match="must have 6 entries"):
        fk(arm, [0.0] * 7)
    with pytest.raises(ModelError, match="unknown link 'flange'"):
        fk(arm, np.zeros(6), "flange")
    with pytest.raises(ModelError, match=r"must be \(N, 6\)"):
        fk_batch(arm, np.zeros((3, 5)))
