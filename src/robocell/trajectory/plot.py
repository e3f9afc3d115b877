"""Plot a trajectory: positions, velocities and accelerations over time, with the limits."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocell.errors import PlanningError
from robocell.robot.model import JointGroup
from robocell.trajectory.timing import joint_limits
from robocell.trajectory.trajectory import JointTrajectory


def plot_trajectory(
    trajectory: JointTrajectory,
    path: str | Path,
    group: JointGroup | None = None,
    dt: float = 0.002,
) -> Path:
    """Write a PNG of the trajectory's positions, velocities and accelerations (sampled every
    ``dt`` [s]); with ``group``, the limits it was timed with are drawn as dashed lines
    (:func:`robocell.trajectory.timing.joint_limits`). Returns the file's path."""
    if not isinstance(trajectory, JointTrajectory):
        raise PlanningError(
            f"plot_trajectory needs a JointTrajectory, got {type(trajectory).__name__}"
        )
    if not isinstance(path, str | Path):
        raise PlanningError(f"plot_trajectory needs a file path, got {path!r}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.union1d(np.arange(0.0, trajectory.duration, dt), [trajectory.duration])
    s = trajectory.sample(t)
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    rows = (
        ("position [rad]", s.positions, None),
        (
            "velocity [rad/s]",
            s.velocities,
            None if group is None else joint_limits(group, "velocity"),
        ),
        (
            "acceleration [rad/s²]",
            s.accelerations,
            None if group is None else joint_limits(group, "acceleration"),
        ),
    )
    for ax, (label, values, limit) in zip(axes, rows, strict=True):
        for j, name in enumerate(trajectory.joint_names):
            line = ax.plot(t, values[:, j], label=name, linewidth=1.2)[0]
            if limit is not None:
                for sign in (-1, 1):
                    ax.axhline(sign * limit[j], color=line.get_color(), linestyle="--", lw=0.6)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=7, ncol=2)
    axes[-1].set_xlabel("time [s]")
    title = f"{trajectory.group or 'trajectory'}: {trajectory.duration:.3f} s"
    fig.suptitle(title)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
