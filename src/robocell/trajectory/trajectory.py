"""Joint trajectories: knots (time, position, velocity, acceleration) joined by quintic Hermite
segments, so that positions, velocities and accelerations are continuous and exact at the knots.

Every trajectory robocell makes is built from knots sampled from an exact profile (TOPP-RA,
trapezoid, ruckig) a few milliseconds apart, so the quintic between two knots follows the
profile to well under a micrometre.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import PlanningError, floats, number
from robocell.robot.model import JointGroup
from robocell.trajectory import _kernels as TK

#: [rad or m] how far outside a joint's position limits a trajectory may go before it counts
#: as outside them (rounding of the samples between knots)
POSITION_SLACK = 1e-6


@dataclass(frozen=True)
class TrajectorySample:
    """States at times ``t`` (M,): positions, velocities, accelerations (M, dof)."""

    t: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    accelerations: NDArray[np.float64]


@dataclass
class JointTrajectory:
    """A timed joint trajectory of a group (MoveIt's RobotTrajectory / JointTrajectory).

    ``times`` (K,) [s] start at 0 and increase; ``positions``, ``velocities``, ``accelerations``
    (K, dof) in the group's joint order, [rad], [rad/s], [rad/s²] (or [m…] for prismatic joints).
    """

    joint_names: list[str]
    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    accelerations: NDArray[np.float64]
    group: str = ""
    info: dict[str, float] = field(default_factory=dict)
    #: (K-1, 2, dof) accelerations at the start and end of each knot interval, where they
    #: differ from the knots' (a time-optimal profile switches acceleration at grid points)
    segment_accelerations: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        k, n = self.positions.shape[0], len(self.joint_names)
        seg = self.segment_accelerations
        if seg is not None and seg.shape != (max(k - 1, 0), 2, n):
            raise PlanningError(f"segment accelerations must be ({k - 1}, 2, {n}), got {seg.shape}")
        for name in ("positions", "velocities", "accelerations"):
            arr = getattr(self, name)
            if arr.shape != (k, n):
                raise PlanningError(f"trajectory {name} must be ({k}, {n}), got {arr.shape}")
        if self.times.shape != (k,) or k < 1:
            raise PlanningError(f"trajectory times must be ({k},) with k >= 1")
        if k > 1 and not np.all(np.diff(self.times) > 0):
            raise PlanningError("trajectory times must increase strictly")
        if not all(np.all(np.isfinite(getattr(self, a))) for a in ("times", "positions")):
            raise PlanningError("trajectory contains NaN or infinity")

    @property
    def duration(self) -> float:
        """Length in time [s]."""
        return float(self.times[-1] - self.times[0])

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    @property
    def start(self) -> NDArray[np.float64]:
        return self.positions[0].copy()

    @property
    def end(self) -> NDArray[np.float64]:
        return self.positions[-1].copy()

    def __len__(self) -> int:
        return int(self.times.shape[0])

    def __repr__(self) -> str:
        return (
            f"JointTrajectory(group={self.group!r}, {len(self)} knots, "
            f"duration={self.duration:.3f} s)"
        )

    def sample(self, t: ArrayLike) -> TrajectorySample:
        """States at times ``t`` (scalar or (M,)) [s], clamped to [0, duration]."""
        raw = np.atleast_1d(floats(t, "sample times [s]", PlanningError))
        if raw.ndim != 1 or raw.shape[0] == 0 or not np.all(np.isfinite(raw)):
            raise PlanningError(f"sample times must be finite numbers [s], got {t!r}")
        ts = np.clip(raw, self.times[0], self.times[-1])
        if len(self) == 1:
            m = ts.shape[0]
            z = np.zeros((m, self.dof))
            return TrajectorySample(ts, np.tile(self.positions[0], (m, 1)), z, z.copy())
        # quintic Hermite on each knot interval: positions, velocities and accelerations
        # matching at both of its knots
        if self.segment_accelerations is None:
            a0, a1 = self.accelerations[:-1], self.accelerations[1:]
        else:
            a0, a1 = self.segment_accelerations[:, 0], self.segment_accelerations[:, 1]
        pos, vel, acc = TK.quintic_states(
            _c(self.times), _c(self.positions), _c(self.velocities), _c(a0), _c(a1), ts
        )
        return TrajectorySample(ts, pos, vel, acc)

    def positions_at(self, t: float) -> NDArray[np.float64]:
        """Positions (dof,) at time ``t`` [s]."""
        return self.sample(t).positions[0]

    def resample(self, dt: float) -> JointTrajectory:
        """The same motion with knots every ``dt`` [s] (and at the end)."""
        if not number(dt, "dt [s]", PlanningError) > 0:
            raise PlanningError(f"dt must be > 0, got {dt!r}")
        n = max(1, int(np.ceil(self.duration / dt - 1e-9)))
        ts = np.minimum(np.arange(n + 1) * dt, self.duration) + self.times[0]
        ts = np.unique(ts)
        s = self.sample(ts)
        return JointTrajectory(
            self.joint_names,
            ts - ts[0],
            s.positions,
            s.velocities,
            s.accelerations,
            self.group,
            dict(self.info),
        )

    def scaled(self, k: float) -> JointTrajectory:
        """The same path ``k`` times slower (k < 1: faster, which may leave the limits; the
        execution checks them): velocities / k, accelerations / k²."""
        if not number(k, "time scale k", PlanningError) > 0:
            raise PlanningError(f"time scale k must be > 0, got {k!r}")
        return JointTrajectory(
            self.joint_names,
            self.times * k,
            self.positions.copy(),
            self.velocities / k,
            self.accelerations / (k * k),
            self.group,
            dict(self.info),
            None if self.segment_accelerations is None else self.segment_accelerations / (k * k),
        )

    def then(self, other: JointTrajectory) -> JointTrajectory:
        """This trajectory followed by ``other`` (which must start where this one ends)."""
        if not isinstance(other, JointTrajectory):
            raise PlanningError(f"then() needs a JointTrajectory, got {type(other).__name__}")
        if other.joint_names != self.joint_names:
            raise PlanningError("cannot join trajectories of different joints")
        if not np.allclose(other.positions[0], self.positions[-1], rtol=0.0, atol=1e-6):
            raise PlanningError("the second trajectory does not start where the first ends")
        t = np.concatenate([self.times, self.times[-1] + other.times[1:]])
        cat = lambda a, b: np.vstack([a, b[1:]])  # noqa: E731
        return JointTrajectory(
            self.joint_names,
            t,
            cat(self.positions, other.positions),
            cat(self.velocities, other.velocities),
            cat(self.accelerations, other.accelerations),
            self.group,
            segment_accelerations=np.concatenate([self._segments(), other._segments()], axis=0),
        )

    def _segments(self) -> NDArray[np.float64]:
        if self.segment_accelerations is not None:
            return self.segment_accelerations
        a = self.accelerations
        return np.stack([a[:-1], a[1:]], axis=1)

    def limit_violations(
        self,
        group: JointGroup,
        velocity_scaling: float = 1.0,
        acceleration_scaling: float = 1.0,
        dt: float = 0.002,
        rel_tol: float = 1e-3,
    ) -> list[str]:
        """Where the trajectory leaves the group's position, velocity or acceleration limits
        (sampled every ``dt`` [s] and at every knot); empty when it stays within them."""
        ts = np.union1d(self.times, np.arange(0.0, self.duration, dt))
        s = self.sample(ts)
        out = []
        checks = (
            ("position", s.positions, group.lower, group.upper, POSITION_SLACK),
            (
                "velocity",
                s.velocities,
                -group.velocity * velocity_scaling,
                group.velocity * velocity_scaling,
                rel_tol,
            ),
            (
                "acceleration",
                s.accelerations,
                -group.acceleration * acceleration_scaling,
                group.acceleration * acceleration_scaling,
                rel_tol,
            ),
        )
        for what, vals, lo, hi, tol in checks:
            slack = tol * np.maximum(np.abs(hi), 1.0) if what != "position" else tol
            excess = np.maximum(lo - vals, vals - hi)  # > 0 outside the limits
            bad = excess > slack
            for j in np.flatnonzero(bad.any(axis=0)):
                k = int(np.argmax(excess[:, j]))  # the sample farthest outside
                out.append(
                    f"{group.joint_names[j]} {what} {vals[k, j]:.4f} at t={ts[k]:.3f} s "
                    f"outside [{lo[j]:.4f}, {hi[j]:.4f}]"
                )
        return out

    def waypoints(self) -> NDArray[np.float64]:
        """The knot positions (K, dof)."""
        return self.positions.copy()


def stationary(group: JointGroup, q: ArrayLike) -> JointTrajectory:
    """A trajectory of one knot that holds ``q``."""
    qv = group.as_joint_vector(q)[None, :]
    z = np.zeros_like(qv)
    return JointTrajectory(list(group.joint_names), np.zeros(1), qv.copy(), z, z.copy(), group.name)


def _c(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """``a`` as a C-contiguous float array (the compiled kernels' one layout)."""
    return np.ascontiguousarray(a, dtype=float)
