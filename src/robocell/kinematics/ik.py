"""Inverse kinematics: analytic (OPW, UR) and numeric (Levenberg–Marquardt with restarts), and
:func:`solve_ik`, which picks the solver that fits the group and can require collision-free
solutions.

Targets are the pose of the group's tip link (or another link) in the group's *base* frame,
``T_base_tip``; solutions are joint vectors in the group's order, ordered by distance to the seed.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import IKError, ModelError, floats, name_or
from robocell.geometry.pose import Pose, invert_transform, rotation_error
from robocell.kinematics import _kernels as K
from robocell.kinematics import analytic as A
from robocell.kinematics.fk import fk, tree_args
from robocell.robot.model import JointGroup, RobotModel


@dataclass
class IKResult:
    """Solutions (K, dof) ordered by distance to the seed (empty when none); ``reason`` says why
    there are none. ``solver`` names the solver used."""

    solutions: NDArray[np.float64]
    solver: str
    reason: str = ""
    attempts: int = 0

    @property
    def success(self) -> bool:
        return len(self.solutions) > 0

    @property
    def best(self) -> NDArray[np.float64]:
        """The solution nearest the seed; an :class:`IKError` when there is none."""
        if not self.success:
            raise IKError(f"no IK solution: {self.reason}")
        return self.solutions[0]


class IKSolver(Protocol):
    """What every IK solver offers."""

    name: str
    group: JointGroup
    tip_link: str

    def solve(
        self,
        T_base_tip: NDArray[np.float64],
        seed: NDArray[np.float64] | None = None,
        rng: np.random.Generator | None = None,
        timeout: float = 0.05,
        max_solutions: int = 1,
    ) -> IKResult: ...


_EYE3 = np.eye(3)
_CLOSED_FORM_TOL = 1e-7  # a closed-form solution's pose error that counts as exact


def as_target(target: Pose | ArrayLike) -> NDArray[np.float64]:
    """A 4×4 target from a Pose or a 4×4 array (validated: finite, rigid)."""
    if isinstance(target, Pose):
        return target.matrix()
    T = floats(target, "an IK target (a Pose or a 4x4 matrix)", IKError)
    if T.shape != (4, 4):
        raise IKError(f"an IK target must be a Pose or a 4x4 matrix, got shape {T.shape}")
    # one sum proves every entry finite; np.allclose costs ten times this whole check
    R = T[:3, :3]
    if not math.isfinite(float(T.sum())):
        raise IKError("the IK target contains NaN or infinity")
    if float(np.abs(R @ R.T - _EYE3).max()) > 1e-6:
        raise IKError("the IK target's rotation is not orthonormal")
    return T


def _order_by_seed(sols: NDArray[np.float64], seed: NDArray[np.float64]) -> NDArray[np.float64]:
    if len(sols) == 0:
        return sols
    d = np.linalg.norm(sols - seed, axis=1)
    return sols[np.argsort(d, kind="stable")]


class AnalyticIK:
    """Closed-form IK (OPW or UR) for a 6-joint chain, tied to the URDF by fitted transforms:
    ``T_base_tip(q) = T_base_canon @ FK_canonical(sign·q − offset) @ T_flange_tip``.

    The fit is verified on random configurations at construction; a mismatch raises
    :class:`ModelError` (the parameters do not describe this robot).
    """

    def __init__(
        self,
        group: JointGroup,
        params: A.OPWParameters | A.URParameters,
        tip_link: str | None = None,
        tol_pos: float = 1e-9,
        tol_rot: float = 1e-9,
    ) -> None:
        if group.dof != 6:
            raise ModelError(f"analytic IK needs 6 joints; group {group.name!r} has {group.dof}")
        self.group = group
        self.tip_link = tip_link or group.tip_link
        self.kind = 0 if isinstance(params, A.OPWParameters) else 1
        self.name = "opw" if self.kind == 0 else "ur"
        self.params = params
        self._p = params.array()
        self._signs = np.asarray(params.signs, float)
        self._offsets = np.asarray(params.offsets, float)
        self._wrist = 3 if self.kind == 0 else 5  # the joint whose seed picks a wrist flip
        self.tol_pos, self.tol_rot = tol_pos, tol_rot
        self._fit()

    def _canon_fk(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        qc = self._signs * q - self._offsets
        return A.opw_fk(self._p, qc) if self.kind == 0 else A.ur_fk(self._p, qc)

    def _urdf_fk(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        return fk(self.group, q, self.tip_link, relative_to=self.group.base_link)

    def _fit(self) -> None:
        """Find T_base_canon = Rz(α) and T_flange_tip. The canonical base sits at the group's base
        link up to a rotation α about joint 1's axis (UR's 'base' vs 'base_link' differ by π);
        candidates for α come from the tip's azimuth, and each is verified."""
        g = self.group
        rng = np.random.default_rng(7)
        q0 = np.clip(np.zeros(6), g.lower, g.upper)
        T_u0, T_c0 = self._urdf_fk(q0), self._canon_fk(q0)
        az = math.atan2(T_u0[1, 3], T_u0[0, 3]) - math.atan2(T_c0[1, 3], T_c0[0, 3])
        tests = [g.random(rng) for _ in range(24)]
        for alpha in (az, 0.0, math.pi, math.pi / 2, -math.pi / 2):
            c, s = math.cos(alpha), math.sin(alpha)
            T_bc = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
            T_ft = invert_transform(T_bc @ T_c0) @ T_u0
            if all(
                np.allclose(T_bc @ self._canon_fk(q) @ T_ft, self._urdf_fk(q), atol=1e-7)
                for q in tests
            ):
                self.T_base_canon, self.T_flange_tip = T_bc, T_ft
                self._T_canon_base = invert_transform(T_bc)
                self._T_tip_flange = invert_transform(T_ft)
                return
        raise ModelError(
            f"the {self.name} parameters {self.params} do not describe group {g.name!r} "
            f"(base {g.base_link!r}, tip {self.tip_link!r}): forward kinematics disagree"
        )

    def solve(
        self,
        T_base_tip: NDArray[np.float64],
        seed: NDArray[np.float64] | None = None,
        rng: np.random.Generator | None = None,
        timeout: float = 0.05,
        max_solutions: int = 0,
    ) -> IKResult:
        """Every solution within limits, nearest the seed first (``max_solutions`` > 0 keeps
        only that many). ``rng`` and ``timeout`` are unused: the answer is immediate."""
        sols = A.solve_ordered(self.kind, self._p, T_base_tip, *self._solve_args(seed))
        if max_solutions > 0:
            sols = sols[:max_solutions]
        reason = (
            ""
            if len(sols)
            else "the pose is out of reach (or every solution is outside the joint limits)"
        )
        return IKResult(sols, self.name, reason, 1)

    def solve_many(
        self, Ts: NDArray[np.float64], seed: NDArray[np.float64] | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """:meth:`solve` for each of the targets ``Ts`` (N, 4, 4), base frame, valid already, in
        one compiled call: the solutions of them all (S, 6), each target's nearest the seed
        first, target after target, and how many each has (N,). Grasp and place candidates
        ask hundreds at once: one call each cost 43 µs, 20 of them outside the solver."""
        Ts = np.ascontiguousarray(Ts, dtype=np.float64).reshape(-1, 4, 4)
        if not math.isfinite(float(Ts.sum())):
            raise IKError("an IK target contains NaN or infinity")
        return A.solve_ordered_many(self.kind, self._p, Ts, *self._solve_args(seed))  # type: ignore[no-any-return]

    def _solve_args(self, seed: NDArray[np.float64] | None) -> tuple[Any, ...]:
        """The closed-form solvers' arguments after the target (A.solve_ordered's)."""
        g = self.group
        seed_q = np.asarray(g.default_positions if seed is None else seed, dtype=np.float64)
        return (
            self._T_canon_base,
            self._T_tip_flange,
            seed_q,
            self._signs,
            self._offsets,
            g.lower,
            g.upper,
            self._wrist,
            _CLOSED_FORM_TOL,
        )

    def follow_line(
        self,
        T_start: NDArray[np.float64],
        offset: NDArray[np.float64],
        q: NDArray[np.float64],
        steps: int,
        max_jump: float,
    ) -> tuple[NDArray[np.float64], bool]:
        """The configurations along the straight line of the tip from ``T_start`` (base frame)
        by ``offset`` in ``steps`` equal steps, each the solution nearest the one before
        (from ``q``, as :meth:`solve` orders them), and whether the line was followed to its
        end (it stops before a step without a solution or one that jumps by more than
        ``max_jump`` rad). One compiled call: a Python loop over :func:`solve_ik` cost 67 µs
        a step, 9000 steps per sorting layout (measured)."""
        g = self.group
        return A.follow_line(  # type: ignore[no-any-return]
            self.kind, self._p, np.ascontiguousarray(T_start, dtype=float),
            np.ascontiguousarray(offset, dtype=float), int(steps),
            np.ascontiguousarray(q, dtype=float), self._T_canon_base, self._T_tip_flange,
            self._signs, self._offsets, g.lower, g.upper, self._wrist, _CLOSED_FORM_TOL,
            float(max_jump),
        )  # fmt: skip


@dataclass
class NumericIKConfig:
    """Numeric IK settings: tolerances in [m] and [rad], iterations per attempt, restarts drawn
    per batch, whether only the position counts."""

    tol_pos: float = 1e-6
    tol_rot: float = 1e-6
    max_iter: int = 60
    restarts_per_batch: int = 32
    position_only: bool = False


class NumericIK:
    """Levenberg–Marquardt IK on any chain (compiled), joint-limit aware, with random restarts
    from a seeded Generator until a solution is found or the time budget runs out (TRAC-IK's
    recipe, minus the SQP half)."""

    name = "numeric"

    def __init__(
        self,
        group: JointGroup,
        tip_link: str | None = None,
        config: NumericIKConfig | None = None,
        base_positions: ArrayLike | None = None,
    ) -> None:
        robot = group.robot
        if robot is None or group.dof == 0:
            raise ModelError(f"group {group.name!r} has no joints to solve for")
        self.group = group
        self.robot: RobotModel = robot
        self.tip_link = tip_link or group.tip_link
        self.config = config or NumericIKConfig()
        self._tip = robot.link_index(self.tip_link)
        self._base = robot.link_index(group.base_link) if group.base_link else None
        self._args = tree_args(robot)
        self._joints = self._args.joints_to(
            self._tip, *([self._base] if self._base is not None else [])
        )
        self.set_base_positions(base_positions)

    def set_base_positions(self, base_positions: ArrayLike | None) -> None:
        """Values of the joints outside the group (they fix where the base is)."""
        r = self.robot
        self._full = np.array(
            r.default_positions if base_positions is None else base_positions, float
        )
        if self._base is None:
            self._T_root_base = np.eye(4)
        else:
            T = np.empty((self._args.n_links, 4, 4))
            K.fk_into(self._full, self._joints, self._args.root, *self._args.arrays, T)
            self._T_root_base = T[self._base].copy()

    def solve(
        self,
        T_base_tip: NDArray[np.float64],
        seed: NDArray[np.float64] | None = None,
        rng: np.random.Generator | None = None,
        timeout: float = 0.05,
        max_solutions: int = 1,
    ) -> IKResult:
        """Up to ``max_solutions`` distinct solutions, nearest the seed first."""
        g, c = self.group, self.config
        rng = rng if rng is not None else np.random.default_rng(0)
        seed_q = g.default_positions.copy() if seed is None else np.clip(seed, g.lower, g.upper)
        T_target = self._T_root_base @ T_base_tip
        found: list[NDArray[np.float64]] = []
        deadline = time.perf_counter() + timeout
        attempts = 0
        first = True
        while True:
            seeds = g.random(rng, c.restarts_per_batch)
            if first:
                seeds[0] = seed_q
                first = False
            q, ok, used, _ = K.numeric_ik(
                T_target,
                self._full,
                g.indices,
                seeds,
                g.lower,
                g.upper,
                self._tip,
                self._joints,
                self._args.root,
                *self._args.arrays,
                self._args.n_links,
                c.tol_pos,
                c.tol_rot,
                c.max_iter,
                c.position_only,
            )
            attempts += int(used)
            if ok and not any(np.allclose(q, f, atol=1e-4) for f in found):
                found.append(q)
            if len(found) >= max_solutions or time.perf_counter() > deadline:
                break
        sols = _order_by_seed(np.array(found).reshape(-1, g.dof), seed_q)
        reason = (
            "" if found else f"no solution found in {timeout * 1e3:.0f} ms ({attempts} attempts)"
        )
        return IKResult(sols, self.name, reason, attempts)


def ik_solver(group: JointGroup, tip_link: str | None = None) -> AnalyticIK | NumericIK:
    """The solver that fits the group: the analytic one its robot's kinematics config names
    (kinematics.yaml: ``<group>: {solver: opw|ur, parameters: {...}}``) for its tip, else
    numeric. Solvers are built once per (robot, group, tip) and reused."""
    robot = group.robot
    if robot is None:
        raise ModelError(f"group {group.name!r} is not attached to a robot model")
    tip = name_or(tip_link, group.tip_link)
    if not isinstance(tip, str):
        robot.link_index(tip, "IK tip link")  # refuses it, naming the links
    key = (group.name, tip)
    # kept on the robot, so that they go with it (a module-level cache keyed by the robot kept
    # every robot a process loaded alive, with its collision model: 80 MB per sorting layout)
    solvers: dict[tuple[str, str], Any] = vars(robot).setdefault("_ik_solvers", {})
    if key not in solvers:
        cfg = robot.kinematics_config.get(group.name)
        solver: AnalyticIK | NumericIK
        if cfg and cfg.get("solver") in ("opw", "ur"):
            solver = AnalyticIK(group, A.parameters_from_config(cfg), tip)
        else:
            solver = NumericIK(group, tip)
        solvers[key] = solver
    return solvers[key]  # type: ignore[no-any-return]


class _Checker(Protocol):
    def check(self, qs: NDArray[np.float64]) -> NDArray[np.bool_]: ...


def solve_ik(
    group: JointGroup,
    T_base_tip: Pose | ArrayLike,
    seed: ArrayLike | None = None,
    checker: _Checker | None = None,
    collision_free: bool = True,
    tip_link: str | None = None,
    timeout: float = 0.05,
    max_solutions: int = 0,
    rng: np.random.Generator | int | None = None,
) -> IKResult:
    """Solve IK for ``group``: the target pose of ``tip_link`` (default: the group's tip) in the
    group's base frame. Solutions are ordered by distance to ``seed``.

    With a ``checker`` (a scene's :class:`~robocell.scene.CollisionChecker` for this group) and
    ``collision_free``, only collision-free solutions are returned; the reason then says whether
    the pose was out of reach or only blocked by collisions. ``max_solutions`` = 0: all the
    analytic solver finds, or 1 from the numeric solver.
    """
    T = as_target(T_base_tip)
    seed_q = None if seed is None else group.as_joint_vector(seed, "IK seed")
    solver = ik_solver(group, tip_link)
    want_free = checker is not None and collision_free
    if isinstance(solver, NumericIK):
        # made here only: the closed form needs none, and a generator seeded from the OS
        # cost 10 of a call's 43 µs
        gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        n_wanted = max(1, max_solutions)
        result = solver.solve(T, seed_q, gen, timeout, n_wanted)
        if want_free and result.success:
            assert checker is not None
            deadline = time.perf_counter() + timeout
            kept = result.solutions[~checker.check(result.solutions)]
            tries = 0
            while len(kept) == 0 and time.perf_counter() < deadline and tries < 50:
                tries += 1
                more = solver.solve(T, None, gen, max(0.0, deadline - time.perf_counter()), 4)
                if more.success:
                    kept = more.solutions[~checker.check(more.solutions)]
            if len(kept) == 0:
                return IKResult(
                    kept,
                    result.solver,
                    "the pose is reachable but every solution found is in collision",
                    result.attempts,
                )
            result = IKResult(
                _order_by_seed(kept, seed_q if seed_q is not None else kept[0]),
                result.solver,
                "",
                result.attempts,
            )
        return result
    result = solver.solve(T, seed_q, None, timeout, 0)
    sols = result.solutions
    if want_free and len(sols):
        assert checker is not None
        sols = sols[~checker.check(sols)]
        if len(sols) == 0:
            return IKResult(
                sols,
                result.solver,
                f"the pose is reachable but all {len(result.solutions)} solutions are in collision",
                1,
            )
    if max_solutions > 0:
        sols = sols[:max_solutions]
    return IKResult(sols, result.solver, result.reason, 1)


def pose_error(T_a: NDArray[np.float64], T_b: NDArray[np.float64]) -> tuple[float, float]:
    """(position error [m], rotation error [rad]) between two poses."""
    return float(np.linalg.norm(T_a[:3, 3] - T_b[:3, 3])), rotation_error(T_a[:3, :3], T_b[:3, :3])
