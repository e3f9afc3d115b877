"""A continuous collision check of a motion: every configuration along a path proven free, not
only sampled states (MoveIt's and OMPL's checks are discrete: between two checked states a thin
part can pass into an obstacle; robocell's discrete final check let 16 of 280 MotionBenchMaker
paths do so, by up to 2.00 mm).

The math (after Schwarzer, Saha and Latombe, "Exact collision checking of robot paths", 2002):
a revolute joint turning by dθ moves a point at distance ρ from its axis by ρ·|dθ|, so along a
path a point of body b moves at most Σ_k |dq_k| ρ_bk. Everywhere, ρ_bk ≤ R_bk, the length of
the chain from joint k to the body plus the body's reach (:func:`motion_radii`). Near one
configuration it is tighter: ρ_bk is at most the distance d_bk of the body's bounding sphere
from joint k's axis there, plus how far the joints below k can move the body meanwhile (the
joints above k move the axis and the body together, and k's own turn keeps the distance).

So a part of a path, of arc length h in joint space, along which joint k moves at most w_k per
unit of arc length (BlendedPath.speed_bounds), keeps body b within

    pad_b = h/2 · Σ_k w_k (d_bk + h/2 · Σ_{j below k} w_j R_bj)

of where it is at the part's middle (and within h/2 · Σ_k w_k R_bk, whichever is smaller). If,
at the middle, every body grown by its pad is clear of the obstacles, and the two bodies of
every self pair are farther apart than their pads over the joints one has and the other lacks,
the whole part is free. The kernel (:mod:`robocell.scene._swept_kernels`) proves that with the
collision kernel's own levels, grown: the world's distance grid and exact obstacle distances
against the grown sphere trees; where grown leaves touch, the body's triangles or primitives
against the obstacle grown by the pad; a self pair's table over every cell the part can reach,
or its distance field, or its two trees.

A path is cut into parts whose pads are at most ``first_pad`` by the bounds everywhere; the
parts not proven free are halved, level after level (compiled, in one call). A part still not
proven when its pads reach ``tolerance`` (0.1 mm) is checked exactly at its middle, as the
checker checks a state: if it is free there, no point of the part lies deeper than the
tolerance in an obstacle. Two links are held to ``self_tolerance`` (0.5 mm) the same way: a
part proven but for self pairs whose pads are that small is checked exactly at its middle. A
path that would take more than BUDGET tests per first part is not proven (SweptResult says
where, and that it was not found to collide). Parts near an obstacle need short pads; parts in
the open are proven in one test.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import SceneError
from robocell.kinematics._kernels import PRISMATIC, REVOLUTE
from robocell.scene import _kernels as K
from robocell.scene import _swept_kernels as SW
from robocell.scene.checker import next_epoch

if TYPE_CHECKING:
    from robocell.scene.checker import CollisionChecker

# [m] the pads of the first test of a path: the largest pad of its pieces (a Panda's finger)
FIRST_PAD = 0.05
# [m] the least pad: a part not proven free with pads this small is free to this depth when its
# middle is (the exact check's). 0.1 mm: 10 µm took 2,500 parts where a Panda's link 6 skims a
# box 11–60 µm away over 0.05 rad (MotionBenchMaker box 8), past the check's budget
TOLERANCE = 1e-4
# [m] pads below which a grown leaf that touches an obstacle has the body's pieces tested
PIECES_BELOW = 0.006
# parts left unproven at a level beyond which their midpoints are checked exactly (see
# SweptCheck.check_path)
EXACT_AFTER = 32
# the states a path's check may test, per part it starts with: beyond, it is not proven
BUDGET = 64
# [m] the tolerance of self pairs: two links may pass this deep into each other where the
# path is checked exactly that close to them (the UR5's wrist 2 skims its forearm within
# 0.1–0.9 mm over wide bands of wrist angles: 0.01 mm took thousands of exact checks per path)
SELF_TOLERANCE = 0.0005


class MotionRadii(NamedTuple):
    """How far the checker's kernel bodies can move: ``joint[b, k]`` [m/rad, or m/m for a
    prismatic joint] bounds how far a point of body b moves per unit change of the group
    variable of joint k (the robot tree's joint order), for any configuration; ``chain[b, k]``
    says whether joint k lies between the root and body b."""

    joint: NDArray[np.float64]
    chain: NDArray[np.bool_]
    # (B, C): the group's joints on each body's chain, from the body towards the root, −1 after
    order: NDArray[np.int64]

    def per_variable(
        self, var: NDArray[np.int64], columns: NDArray[np.int64]
    ) -> NDArray[np.float64]:
        """(B, V): the bound per group variable (columns: the group's full variable indices),
        summed over the joints it drives (a mimic joint adds its own)."""
        out = np.zeros((self.joint.shape[0], len(columns)))
        for c, v in enumerate(columns):
            out[:, c] = self.joint[:, var == v].sum(axis=1)
        return out


def motion_radii(checker: CollisionChecker) -> MotionRadii:
    """:class:`MotionRadii` of the checker's kernel bodies.

    Walking from the body's link towards the root: D bounds the distance of the body's points
    from the current link's frame origin (first the body's bounding sphere seen from its link's
    origin). A revolute joint's axis passes through its child link's origin, so it moves them
    by at most D per radian; then D grows by the length of the joint's fixed offset in its
    parent link (and by a prismatic joint's travel)."""
    model = checker.kernel_inputs()[0]
    f = K.MODEL_FIELDS.index
    body_link = model[f("body_link")]
    body_T = model[f("body_T")]
    body_root = model[f("body_root")]
    nodes = model[f("nodes")]
    t = checker.robot.tree
    n_joints = len(t.child_link)
    parent_joint = np.full(t.n_links, -1, np.int64)
    parent_joint[t.child_link] = np.arange(n_joints)
    column = {int(v): i for i, v in enumerate(checker.group.indices)}
    base = checker.base_positions
    travel = np.maximum(np.abs(checker.group.lower), np.abs(checker.group.upper))
    R = np.zeros((len(body_link), n_joints))
    chain = np.zeros((len(body_link), n_joints), np.bool_)
    order = np.full((len(body_link), max(1, len(column))), -1, np.int64)
    for b in range(len(body_link)):
        n_own = 0
        c = nodes[body_root[b]]
        centre = body_T[b, :3, :3] @ c[:3] + body_T[b, :3, 3]
        D = float(np.linalg.norm(centre) + c[3])
        k = int(parent_joint[body_link[b]])
        while k >= 0:
            chain[b, k] = True
            v = int(t.var[k])
            col = column.get(v, -1)
            gain = abs(float(t.mult[k]))
            if col >= 0 and t.type[k] in (REVOLUTE, PRISMATIC) and n_own < order.shape[1]:
                order[b, n_own] = k
                n_own += 1
            if t.type[k] == REVOLUTE and col >= 0:
                R[b, k] = gain * D
            elif t.type[k] == PRISMATIC:
                if col >= 0:
                    R[b, k] = gain
                    D += gain * float(travel[col]) + abs(float(t.offset[k]))
                elif v >= 0:
                    D += abs(float(t.mult[k]) * float(base[v]) + float(t.offset[k]))
                else:
                    D += abs(float(t.offset[k]))
            D += float(np.linalg.norm(t.origin[k][:3, 3]))
            k = int(parent_joint[t.parent_link[k]])
    return MotionRadii(R, chain, order)


# the kinds of a path's pieces, in piece_arrays()
SEGMENT, ARC, CUBIC = SW.SEGMENT, SW.ARC, SW.CUBIC


class SweptPath(Protocol):
    """A path in the group's joint space, parameterized by ``s`` in [0, length] (arc length
    [rad] for a BlendedPath, chord length for a SplinePath): ``path(s)`` → (N, dof),
    ``path.at(s, piece)`` the same for s known to lie on those pieces; ``speed_bounds()`` →
    (starts (S + 1,), bounds (S, dof)): along each of its S pieces (s from starts[i] to
    starts[i + 1]) no joint moves faster than its bound per unit of s.

    ``piece_arrays()`` describes the pieces for compiled code: (starts (S + 1,), origin, d1,
    d2, d3 (S, dof), radius (S,), kind (S,) int8). On piece k, at x = s − starts[k], the
    position is origin + x·d1 (kind SEGMENT), origin + r cos(x/r)·d1 + r sin(x/r)·d2 (ARC:
    origin its centre, r its radius) or origin + x·d1 + x²·d2 + x³·d3 (CUBIC)."""

    @property
    def length(self) -> float: ...

    def __call__(self, path_positions: ArrayLike, order: int = 0) -> NDArray[np.float64]: ...

    def at(self, s: NDArray[np.float64], piece: NDArray[np.int64]) -> NDArray[np.float64]: ...

    def speed_bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...

    def piece_arrays(self) -> tuple[NDArray[Any], ...]: ...


@dataclass
class SweptResult:
    """The answer of :meth:`SweptCheck.check_path`: ``free`` if every configuration along
    the path is proven free (to the tolerance); else ``at`` [rad], the arc length of a
    configuration that collides (``collides``), or where the path could not be proven free
    within the check's budget (a long stretch of it closer to an obstacle than the parts'
    pads). ``tests``: the configurations tested with pads; ``exact``: those checked as they
    are (where parts were left at the tolerance, or many at once)."""

    free: bool
    at: float
    tests: int
    exact: int
    collides: bool = False


class SweptCheck:
    """Continuous collision checks of paths for one checker (see the module's docstring).

    ``first_pad`` [m]: the largest pad of a path's first pieces; ``tolerance`` [m]: the least
    (a piece not proven free with pads this small is checked exactly at its midpoint);
    ``pieces_below`` [m]: pads below which grown leaves that touch have their pieces tested."""

    def __init__(
        self,
        checker: CollisionChecker,
        first_pad: float = FIRST_PAD,
        tolerance: float = TOLERANCE,
        pieces_below: float = PIECES_BELOW,
        self_tolerance: float = SELF_TOLERANCE,
    ) -> None:
        if not (tolerance > 0 and first_pad >= tolerance and math.isfinite(first_pad)):
            raise SceneError(
                f"a continuous check needs 0 < tolerance <= first_pad, got tolerance "
                f"{tolerance} and first_pad {first_pad}"
            )
        self.checker = checker
        radii = motion_radii(checker)
        var = checker.robot.tree.var
        columns = checker.group.indices.astype(np.int64)
        # (B, dof) [m per rad] how far a point of each kernel body moves per unit of each
        # group variable; (P, dof) the same for the two bodies of each self pair, one seen
        # from the other (the joints on both their chains move them together)
        self.body_radii = radii.per_variable(var, columns)
        model = checker.kernel_inputs()[0]
        pairs = model[K.MODEL_FIELDS.index("self_pairs")]
        a, b = pairs[:, 0], pairs[:, 1]
        own = radii.chain[a] != radii.chain[b]
        rel = MotionRadii(np.where(own, radii.joint[a] + radii.joint[b], 0.0), own, radii.order)
        self.pair_radii = rel.per_variable(var, columns)
        # what the kernel bounds the pads with at each configuration (SW._pads)
        self._R = radii.joint
        self._chain = radii.order
        t = checker.robot.tree
        self._revolute = np.asarray(t.type == REVOLUTE, np.bool_)
        column = {int(v): i for i, v in enumerate(columns)}
        self._joint_column = np.array([column.get(int(v), -1) for v in t.var], np.int64)
        self._gain = np.abs(np.asarray(t.mult, float))
        order = radii.order
        n_pairs = len(pairs)
        self._own_a = np.zeros((n_pairs, order.shape[1]), np.bool_)
        self._own_b = np.zeros((n_pairs, order.shape[1]), np.bool_)
        for p, (i, j) in enumerate(pairs):
            for c in range(order.shape[1]):
                if order[i, c] >= 0 and not radii.chain[j, order[i, c]]:
                    self._own_a[p, c] = True
                if order[j, c] >= 0 and not radii.chain[i, order[j, c]]:
                    self._own_b[p, c] = True
        self.first_pad = first_pad
        self.tolerance = tolerance
        self.pieces_below = pieces_below
        self.self_tolerance = self_tolerance
        self.levels = math.ceil(math.log2(first_pad / tolerance))

    def check_path(self, path: SweptPath) -> SweptResult:
        """Whether ``path`` is free at every configuration (to the tolerance).

        The path is cut into its pieces (speed_bounds); along each, a body moves at most
        Σ_v bound_v R_bv per unit of s (R: :func:`motion_radii`). Each piece is cut into
        equal parts short enough that no body's pad exceeds ``first_pad``; the parts that are
        not proven free are halved, level after level."""
        if self.checker.static_collisions:  # pairs no joint of the group can separate
            return SweptResult(False, 0.0, 0, 0, collides=True)
        starts, bounds = path.speed_bounds()
        body, pair, speed, tail, s0, h, seg = SW.path_parts(
            starts,
            np.ascontiguousarray(bounds),
            self.body_radii,
            self.pair_radii,
            self._joint_column,
            self._gain,
            self._R,
            self._chain,
            self.first_pad,
        )
        chain = self._chain
        if len(seg) == 0:
            return self._exact_at(path, np.array([0.0]), None, 0, 0)
        tests = exact = 0
        limit = max(EXACT_AFTER, len(seg))
        budget = BUDGET * len(seg)
        level = 0
        pieces = path.piece_arrays()
        while True:
            # the parts' pads are at most first_pad / 2^level
            s0, h, seg, level, n, near_s, near_seg = SW.prove_parts(
                s0,
                h,
                seg,
                level,
                self.levels,
                limit,
                budget - tests,
                pieces,
                self.checker.compiled_inputs,
                next_epoch(1 << 40),
                speed,
                tail,
                chain,
                self._revolute,
                self._own_a,
                self._own_b,
                body,
                pair,
                self.pieces_below,
                self.self_tolerance,
            )
            tests += n
            if len(near_s):
                # parts proven but for self pairs within the self tolerance: free to that
                # depth if their middles are
                hit = self._exact_at(path, near_s, near_seg, tests, exact)
                exact = hit.exact
                if not hit.free:
                    return hit
            if len(s0) == 0:
                return SweptResult(True, 0.0, tests, exact)
            # the parts left checked as they are at their midpoints: at the last level, what
            # the tolerance rests on; before, when more are left than the path had parts at
            # first, as a path that collides leaves every part around the collision, twice as
            # many each level
            hit = self._exact_at(path, s0 + h, seg, tests, exact)
            exact = hit.exact
            if not hit.free or level >= self.levels:
                return hit
            if tests + 2 * len(s0) > budget:
                # a long stretch closer to an obstacle than the parts' pads (a link skimming
                # another over a wide band of angles): not proven, where it starts
                return SweptResult(False, float((s0 + h).min()), tests, exact)
            s0 = np.concatenate([s0, s0 + h])
            h = np.concatenate([h, h])
            seg = np.concatenate([seg, seg])
            level += 1
            limit = 4 * len(s0)

    def _exact_at(
        self,
        path: SweptPath,
        s: NDArray[np.float64],
        seg: NDArray[np.int64] | None,
        tests: int,
        exact: int,
    ) -> SweptResult:
        """The checker's own check of the configurations at arc lengths ``s`` (on pieces
        ``seg``, if known): free, or the first (smallest s) that collides."""
        qs = path(s) if seg is None else path.at(s, seg)
        hit = self.checker.check(np.ascontiguousarray(qs))
        if hit.any():
            return SweptResult(False, float(s[hit].min()), tests, exact + len(s), collides=True)
        return SweptResult(True, 0.0, tests, exact + len(s))
