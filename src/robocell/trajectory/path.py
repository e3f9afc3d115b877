"""Geometric paths in joint space: a polyline whose corners are rounded by circular arcs of
bounded deviation (as MoveIt's time-optimal parameterization, Kunz & Stilman 2012, does).

The path is parameterized by arc length ``s`` [rad] (Euclidean in joint space) and gives exact
first and second derivatives, which is what a time-optimal parameterization needs: at a sharp
corner the speed must drop to zero, at a rounded one it need not.
"""

from __future__ import annotations

import abc
import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import PlanningError
from robocell.scene.swept import ARC, CUBIC, SEGMENT
from robocell.trajectory import _kernels as TK


def distinct_waypoints(waypoints: NDArray[np.float64]) -> NDArray[np.int64]:
    """The indices of the (K, dof) waypoints a path goes through: the first, and each that
    differs from the one before (a repeated point has no direction)."""
    step = np.linalg.norm(np.diff(waypoints, axis=0), axis=1)
    return np.flatnonzero(np.concatenate([[True], step > 1e-9]))


class _ArcLengthPath(abc.ABC):
    """What the joint paths share: parameterized by arc length ``s`` ∈ [0, length], stopping
    (if at all) at ``stops``; ``breakpoints`` are where a time parameterization needs grid
    points. A path is called as toppra's geometric paths are (``path(s, order)``, ``dof``,
    ``path_interval``), without deriving from its class: importing toppra took a second
    (it imports matplotlib's pyplot), half of ``import robocell``'s time (session 47)."""

    _dof: int
    _length: float
    breakpoints: NDArray[np.float64]
    stops: list[float]

    @abc.abstractmethod
    def __call__(self, path_positions: ArrayLike, order: int = 0) -> NDArray[np.float64]:
        """The path's points (``order`` 0), first (1) or second (2) derivatives by arc length
        at ``path_positions`` (scalar or (N,)), clamped to [0, length]."""

    @staticmethod
    def _clean(waypoints: ArrayLike) -> NDArray[np.float64]:
        """(K >= 2, dof) waypoints without repeats (a repeated point has no direction)."""
        wp = np.asarray(waypoints, dtype=float)
        if wp.ndim != 2 or wp.shape[0] < 2:
            raise PlanningError(f"a path needs (K >= 2, dof) waypoints, got shape {wp.shape}")
        return wp[distinct_waypoints(wp)]

    @property
    def dof(self) -> int:
        return self._dof

    @property
    def path_interval(self) -> NDArray[np.float64]:
        return np.array([0.0, self._length])

    @property
    def length(self) -> float:
        """Arc length [rad] in joint space."""
        return self._length

    @property
    def waypoints(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self.breakpoints, self(self.breakpoints)

    def split_at_stops(self) -> list[tuple[float, float]]:
        """[s0, s1] intervals between the points where the motion must stop."""
        bounds = [0.0, *self.stops, self._length]
        return [(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if b - a > 1e-12]


class BlendedPath(_ArcLengthPath):
    """Straight segments between ``waypoints`` (K, dof), each interior corner replaced by a
    circular arc that stays within ``max_deviation`` [rad] of the corner and uses at most half
    of each neighbouring segment. ``max_deviation=0`` keeps the sharp corners (the motion
    then stops at each). ``blend_length`` instead sets how far from each corner the arc starts
    (a blend radius, as Pilz's), again at most half of each neighbouring segment. Works in any
    dimension (joint space, or positions in task space)."""

    def __init__(
        self,
        waypoints: ArrayLike,
        max_deviation: float = 0.05,
        blend_length: float | None = None,
    ) -> None:
        wp = self._clean(waypoints)
        if wp.shape[0] < 2:
            wp = np.vstack([wp, wp])
        self._wp = wp
        self._dof = wp.shape[1]
        # segments: ("line", p0, u, length) or ("arc", centre, e1, e2, radius, angle)
        kinds: list[int] = []
        data: list[tuple[NDArray[np.float64], ...]] = []
        lengths: list[float] = []
        n = wp.shape[0]
        u, seg_len, corners = _corner_arcs(wp, max_deviation, blend_length)
        # trim at each interior corner
        trim = np.zeros(n)
        arcs: dict[int, tuple[NDArray[np.float64], ...]] = {}
        for j, i in enumerate(corners.waypoint):
            trim[i] = corners.ell[j]
            r, al = corners.radius[j : j + 1], corners.angle[j : j + 1]
            arcs[int(i)] = (corners.centre[j], corners.e1[j], u[i - 1].copy(), r, al)
        for k in range(n - 1):
            a = wp[k] + trim[k] * u[k] if k > 0 else wp[k]
            length = seg_len[k] - (trim[k] if k > 0 else 0.0) - (trim[k + 1] if k + 1 < n else 0)
            if length > 1e-12 or not lengths:
                kinds.append(0)
                data.append((a, u[k], np.array([max(length, 0.0)])))
                lengths.append(max(length, 0.0))
            if k + 1 in arcs:
                centre, e1, e2, r_, al = arcs[k + 1]
                kinds.append(1)
                data.append(arcs[k + 1])
                lengths.append(float(r_[0] * al[0]))
        self._kinds = np.array(kinds)
        self._on_arc = self._kinds == 1  # which pieces are arcs, for the compiled evaluation
        self._data = data
        self._pieces: tuple[NDArray[Any], ...] | None = None  # piece_arrays(), once made
        self._starts = np.concatenate([[0.0], np.cumsum(lengths)])
        self._length = float(self._starts[-1])
        # boundaries where the curvature jumps: a time parameterization needs a gridpoint there
        self.breakpoints = self._starts.copy()
        # corners left sharp (reversals, or no rounding asked): the motion must stop there
        self.stops = sorted(
            float(self._starts[k + 1])
            for k in range(len(kinds) - 1)
            if kinds[k] == 0
            and kinds[k + 1] == 0
            and float(data[k][1] @ data[k + 1][1]) < 1.0 - 1e-12
        )

    def grid(self, step: float, arc_pieces: int = 12) -> NDArray[np.float64]:
        """Gridpoints for a time parameterization: every ``step`` [rad] on lines, and
        ``arc_pieces`` per arc (the acceleration a curve needs changes fast along it)."""
        # a gridpoint just before each end of an arc too. Before its end: the path is
        # evaluated right-sided at a breakpoint, and the arc's curvature must be seen there as
        # well. Before its start: TOPP-RA holds an interval's one s̈ to the constraints at both
        # its ends, so an interval of the line that ends on the arc must decelerate along the
        # line within what the arc's curvature leaves at its start, and the motion all but
        # stopped there (session 46: an IRB 120 pick motion 6.6 % slower than on a converged
        # grid, 1.7 % in the mean of 40; 0.016 % with this point)
        arc = self._kinds == 1
        ends = np.concatenate([self._starts[:-1][arc], self._starts[1:][arc]])
        pts = [self.breakpoints, np.maximum(ends - 1e-6, 0.0)]
        for k in range(len(self._kinds)):
            a, b = self._starts[k], self._starts[k + 1]
            n = arc_pieces if self._kinds[k] == 1 else max(4, int(math.ceil((b - a) / step)))
            pts.append(np.linspace(a, b, n + 1))
        return np.unique(np.concatenate(pts))

    def __call__(self, path_positions: ArrayLike, order: int = 0) -> NDArray[np.float64]:
        """The path's points (``order`` 0), unit tangents (1) or curvature vectors (2) at arc
        lengths ``path_positions`` (scalar or (N,)), clamped to [0, length]."""
        s = np.asarray(path_positions, dtype=float)
        starts, origin, d1, d2, _, radius, _ = self.piece_arrays()
        out = TK.blended_points(
            starts, origin, d1, d2, radius, self._on_arc, np.ascontiguousarray(s.ravel()), order
        )
        return out[0] if s.ndim == 0 else out  # type: ignore[no-any-return]

    def piece_arrays(self) -> tuple[NDArray[Any], ...]:
        """The pieces of :meth:`speed_bounds` as arrays, for compiled code (see
        :class:`robocell.scene.swept.SweptPath`): segments (origin + x·d1, d1 the direction)
        and arcs (origin the centre)."""
        if self._pieces is None:
            S = len(self._kinds)
            origin, d1, d2 = (
                np.empty((S, self._dof)),
                np.empty((S, self._dof)),
                np.zeros((S, self._dof)),
            )
            radius = np.ones(S)
            for k, kind in enumerate(self._kinds):
                if kind == 0:
                    origin[k], d1[k] = self._data[k][0], self._data[k][1]
                else:
                    origin[k], d1[k], d2[k], r, _ = self._data[k]
                    radius[k] = r[0]
            kinds = np.where(self._kinds == 1, ARC, SEGMENT).astype(np.int8)
            d3 = np.zeros((S, self._dof))
            self._pieces = (self._starts, origin, d1, d2, d3, radius, kinds)
        return self._pieces

    def at(self, s: NDArray[np.float64], piece: NDArray[np.int64]) -> NDArray[np.float64]:
        """(N, dof) positions at arc lengths ``s`` (N,) that lie on pieces ``piece`` (N,)
        (the pieces of :meth:`speed_bounds`): ``path(s)`` without looking the pieces up, in
        one batch of numpy steps."""
        starts, origin, d1, d2, _, radius, kind = self.piece_arrays()
        local = (s - starts[piece])[:, None]
        r = radius[piece][:, None]
        th = local / r
        on_arc = (kind[piece] == ARC)[:, None]
        a = np.where(on_arc, r * np.cos(th), local)
        b = np.where(on_arc, r * np.sin(th), 0.0)
        return origin[piece] + a * d1[piece] + b * d2[piece]

    def speed_bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(starts (S + 1,), bounds (S, dof)): the arc lengths where the path's S pieces
        (segments and arcs) start, and how fast each joint moves at most along each, per unit
        of arc length: |u_j| on a segment of direction u; on an arc, where the direction is
        −sin θ e1 + cos θ e2, at most √(e1_j² + e2_j²)."""
        bounds = np.empty((len(self._kinds), self._dof))
        for k, kind in enumerate(self._kinds):
            if kind == 0:
                bounds[k] = np.abs(self._data[k][1])
            else:
                _, e1, e2, _, _ = self._data[k]
                bounds[k] = np.hypot(e1, e2)
        return self._starts.copy(), bounds

    def sample_states(self, resolution: float, arcs_only: bool = False) -> NDArray[np.float64]:
        """Points along the path (M, dof), consecutive ones at most ``resolution`` apart in
        every joint (a collision check of the path checks these). ``arcs_only``: the rounded
        corners' points alone (the rest lies on the waypoints' straight segments), ends
        included; (0, dof) if there are none."""
        # per segment, the fastest joint's rate |dq_j/ds| sets the step in s
        ss = [] if arcs_only else [self.breakpoints]
        for k in range(len(self._kinds)):
            if arcs_only and self._kinds[k] == 0:
                continue
            a, b = self._starts[k], self._starts[k + 1]
            if self._kinds[k] == 0:
                rate = float(np.max(np.abs(self._data[k][1])))
            else:
                _, e1, e2, _, _ = self._data[k]
                rate = float(np.max(np.hypot(e1, e2)))
            n = max(1, int(math.ceil((b - a) * rate / resolution)))
            ss.append(np.linspace(a, b, n + 1))
        if not ss:
            return np.empty((0, self._dof))
        return self(np.unique(np.concatenate(ss)))


class _Corners(NamedTuple):
    """The rounded corners of a polyline: their ``waypoint`` (index), how far from it each arc
    starts (``ell``), the arc's ``centre``, its unit vector from the centre to the arc's
    start (``e1``; the incoming direction is the other axis of its plane), ``radius`` and
    turning ``angle``."""

    waypoint: NDArray[np.int64]
    ell: NDArray[np.float64]
    centre: NDArray[np.float64]
    e1: NDArray[np.float64]
    radius: NDArray[np.float64]
    angle: NDArray[np.float64]


def _corner_arcs(
    wp: NDArray[np.float64], max_deviation: float, blend_length: float | None
) -> tuple[NDArray[np.float64], NDArray[np.float64], _Corners]:
    """The unit directions and lengths of the segments between waypoints ``wp`` (K, dof)
    without repeats, and the arcs that round their interior corners, as BlendedPath
    describes (compiled: the planner's final check samples them for every path)."""
    u, seg_len, *corners = TK.corner_arcs(
        np.ascontiguousarray(wp, dtype=float),
        float(max_deviation),
        -1.0 if blend_length is None else float(blend_length),
    )
    return u, seg_len, _Corners(*corners)


def arc_states(
    waypoints: ArrayLike, max_deviation: float, resolution: float
) -> NDArray[np.float64]:
    """``BlendedPath(waypoints, max_deviation).sample_states(resolution, arcs_only=True)``
    without building the path: the points of its rounded corners, consecutive ones at most
    ``resolution`` apart in every joint, ends included; (0, dof) if there are none (about
    10 µs for four waypoints, compiled; 85 µs in numpy, 150–177 µs through BlendedPath,
    measured; the planner's final check computes them in its kernel,
    ``planning._kernels.validate_path``)."""
    wp = _ArcLengthPath._clean(waypoints)
    u, _, c = _corner_arcs(wp, max_deviation, None)
    return TK.arc_points(  # type: ignore[no-any-return]
        u, c.waypoint, c.centre, c.e1, c.radius, c.angle, float(resolution)
    )


class SubPath:
    """The stretch [s0, s1] of a path, re-parameterized to start at 0, as a geometric path for
    toppra's own algorithms and constraints (duck-typed as its AbstractGeometricPath)."""

    def __init__(self, path: BlendedPath | SplinePath, s0: float, s1: float) -> None:
        self.path, self.s0, self.s1 = path, s0, s1

    @property
    def dof(self) -> int:
        return self.path.dof

    @property
    def path_interval(self) -> NDArray[np.float64]:
        return np.array([0.0, self.s1 - self.s0])

    def __call__(self, path_positions: ArrayLike, order: int = 0) -> NDArray[np.float64]:
        s = np.clip(np.asarray(path_positions, dtype=float), 0.0, self.s1 - self.s0)
        return self.path(s + self.s0, order)


class SplinePath(_ArcLengthPath):
    """A cubic spline through dense ``waypoints`` (K, dof) parameterized by chord length: the
    path for samples of a smooth curve (a Cartesian line's IK solutions, say), which it follows
    through every sample, without the corners a polyline would have."""

    def __init__(self, waypoints: ArrayLike) -> None:
        from scipy.interpolate import CubicSpline

        wp = self._clean(waypoints)
        if wp.shape[0] < 2:
            wp = np.vstack([wp, wp + 1e-9])
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(wp, axis=0), axis=1))])
        self._spline = CubicSpline(s, wp, bc_type="natural" if len(wp) > 2 else "not-a-knot")
        self._dof = wp.shape[1]
        self._length = float(s[-1])
        self.breakpoints = s
        self.stops = []

    def __call__(self, path_positions: ArrayLike, order: int = 0) -> NDArray[np.float64]:
        s = np.clip(np.asarray(path_positions, dtype=float), 0.0, self._length)
        return np.asarray(self._spline(s, order))

    def piece_arrays(self) -> tuple[NDArray[Any], ...]:
        """The spline's cubic pieces, one between each two waypoints, for compiled code (see
        :class:`robocell.scene.swept.SweptPath`): origin + x·d1 + x²·d2 + x³·d3."""
        c = self._spline.c  # (4, S, dof): x³, x², x, 1
        S = c.shape[1]
        return (
            np.ascontiguousarray(self.breakpoints),
            np.ascontiguousarray(c[3]),
            np.ascontiguousarray(c[2]),
            np.ascontiguousarray(c[1]),
            np.ascontiguousarray(c[0]),
            np.ones(S),
            np.full(S, CUBIC, np.int8),
        )

    def at(self, s: NDArray[np.float64], piece: NDArray[np.int64]) -> NDArray[np.float64]:
        """(N, dof) positions at ``s`` (N,) on pieces ``piece`` (N,) (between waypoints piece
        and piece + 1)."""
        c = self._spline.c
        x = (s - self.breakpoints[piece])[:, None]
        return np.asarray(c[3][piece] + x * (c[2][piece] + x * (c[1][piece] + x * c[0][piece])))

    def speed_bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(starts (S + 1,), bounds (S, dof)): the waypoints' s, and how fast each joint
        moves at most between each two, per unit of s: |q_j'| = |3a x² + 2b x + c| is largest
        at an end of the piece or where q_j'' vanishes within it."""
        c = self._spline.c
        h = np.diff(self.breakpoints)[:, None]
        speed_0 = np.abs(c[2])
        speed_1 = np.abs(3.0 * c[0] * h**2 + 2.0 * c[1] * h + c[2])
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(c[0] != 0.0, -c[1] / (3.0 * c[0]), -1.0)
        inside = (x > 0.0) & (x < h)
        x = np.where(inside, x, 0.0)
        speed_mid = np.where(inside, np.abs(3.0 * c[0] * x**2 + 2.0 * c[1] * x + c[2]), 0.0)
        # a hair above, for the rounding of the products
        bounds = np.maximum(np.maximum(speed_0, speed_1), speed_mid) * (1.0 + 1e-12) + 1e-15
        return self.breakpoints.copy(), bounds

    def grid(self, step: float, arc_pieces: int = 12) -> NDArray[np.float64]:
        """Every waypoint and the midpoints between them, and at least every ``step``."""
        mids = 0.5 * (self.breakpoints[:-1] + self.breakpoints[1:])
        n = max(1, int(math.ceil(self._length / step)))
        return np.unique(
            np.concatenate([self.breakpoints, mids, np.linspace(0, self._length, n + 1)])
        )

    def sample_states(self, resolution: float) -> NDArray[np.float64]:
        """Points at most ``resolution`` apart per joint (the spline's speed bounds the step)."""
        ss = np.linspace(0.0, self._length, 64 * len(self.breakpoints))
        rate = float(np.max(np.abs(self(ss, 1)))) * 1.05
        n = max(1, int(math.ceil(self._length * rate / resolution)))
        return self(np.union1d(np.linspace(0.0, self._length, n + 1), self.breakpoints))
