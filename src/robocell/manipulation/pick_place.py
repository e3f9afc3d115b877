"""Pick and place as stages with fallbacks (MoveIt's pick/place pipeline), on a cell.

``pick`` tries each grasp in quality order: open the gripper, move to the pre-grasp, approach
in a straight line, close, check the object is really between the fingers (physics), attach it
to the planning scene, retreat in a straight line. ``place`` likewise: move to the pre-place
with the object attached, approach, open, detach, retreat, check the object rests where it was
put (physics). Every failure says which stage failed for which candidate, and why; the next
candidate starts from a clean state (gripper open, nothing half-attached).
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robocell.cell.cell import Cell
from robocell.cell.move_group import MoveGroup
from robocell.errors import GraspError, RobocellError
from robocell.geometry.pose import Pose
from robocell.grasping.grasp import Grasp, GripperTranslation, PlaceLocation, Push
from robocell.kinematics.ik import solve_ik
from robocell.trajectory.timing import ptp


@dataclass
class StageResult:
    """One stage of one candidate: ``stage`` (open, move, approach, close, check, attach,
    retreat, release, settle), whether it worked, and why not."""

    candidate: str
    stage: str
    success: bool
    reason: str = ""


@dataclass
class ManipulationResult:
    """The outcome of a pick or a place: the candidate that worked (if any), every stage
    tried, and planning and robot time [s]."""

    success: bool
    candidate: str = ""
    reason: str = ""
    stages: list[StageResult] = field(default_factory=list)
    planning_time: float = 0.0
    robot_time: float = 0.0

    def failures(self) -> list[StageResult]:
        return [s for s in self.stages if not s.success]


class _Failed(Exception):
    def __init__(self, stage: str, reason: str) -> None:
        super().__init__(reason)
        self.stage, self.reason = stage, reason


class _Stopped(_Failed):
    def __init__(self) -> None:
        super().__init__("stopped", "stopped by the user")


def _moved(a: Pose, b: Pose, distance: float = 0.005, angle: float = 0.09) -> str:
    """How an object moved from pose a to b, if by more than ``distance`` [m] or ``angle``
    [rad] (about 5°); "" if it did not."""
    d = float(np.linalg.norm(b.position - a.position))
    R = a.rotation().T @ b.rotation()
    turn = float(np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)))
    if d <= distance and turn <= angle:
        return ""
    return f"{d * 1000:.0f} mm, {np.degrees(turn):.0f}°"


class Manipulator:
    """Pick and place for the cell's arm and gripper. :meth:`stop` (from another thread) ends
    the running pick or place at its next stage, with the robot held where it is."""

    def __init__(
        self, cell: Cell, planning_time: float = 1.0, carry_acceleration: float = 1.0
    ) -> None:
        self.cell = cell
        # acceleration scaling with an object held: lower it for a heavy or loosely held
        # object (at full accelerations none of the 1600 objects of 200 sorting layouts fell
        # on the way; 0.5 cost 0.17 s per object)
        self.carry_acceleration = carry_acceleration
        spec = cell.robot_spec
        if spec.gripper is None:
            raise GraspError(f"robot {spec.name!r} has no gripper group in its cell file")
        self.arm: MoveGroup = cell.move_group(spec.arm)
        self.gripper: MoveGroup = cell.move_group(spec.gripper)
        from robocell.grasping.grasp import GripperGeometry

        self.geometry = GripperGeometry.from_robot(
            cell.robot, spec.gripper, open_command=spec.gripper_command[0],
            closed_command=spec.gripper_command[1],
        )  # fmt: skip
        self.arm.set_end_effector_link(self.geometry.eef_link)
        self.arm.set_planning_time(planning_time)
        self.finger_links = cell.robot.group(spec.gripper).link_names
        # what a held object may touch: the fingers and everything welded to the gripper's
        # mount (its body, the flange): a held object's padding can reach them
        tree, robot = cell.robot.tree, cell.robot
        mount = tree.rigid_root(robot.link_index(self.geometry.eef_link))
        self.hand_links = sorted(
            {*self.finger_links}
            | {lk for lk in robot.link_names if tree.rigid_root(robot.link_index(lk)) == mount}
        )
        self._plan_s = 0.0
        self._robot_s = 0.0
        self._stop = threading.Event()

    def stop(self) -> None:
        """Stop the arm and the gripper now and end the running pick or place (it fails with
        stage "stopped"); the next call starts afresh."""
        self._stop.set()
        self.arm.stop()
        self.gripper.stop()

    def _check_stop(self) -> None:
        if self._stop.is_set():
            raise _Stopped()

    # ------------------------------------------------------------------ helpers
    def _gripper(self, command: float) -> None:
        self._check_stop()
        self.set_gripper(command)

    def set_gripper(self, command: float) -> None:
        """Move the gripper to ``command`` (blocking) and let the fingers settle."""
        g = self.gripper.group
        now = self.gripper.get_current_joint_values()
        traj = ptp(g, np.clip(now, g.lower, g.upper), [command])
        self.cell.controller(g.name).execute(traj).wait()
        self._robot_s += traj.duration
        if self.cell.world is not None:
            self.cell.world.step(50)  # let the fingers settle on what they hold
        else:
            self.cell.scene.state.set_group_positions(g, [command])

    def _move_to(self, pose: Pose, near: np.ndarray | None = None) -> None:
        """Plan and move the end-effector link to ``pose``; with ``near`` (arm joints), to the
        pose's IK solution nearest it (the branch a straight move from there should follow:
        a far-off branch can run a wrist joint into its limit on the way)."""
        self._check_stop()
        target = None
        if near is not None:
            arm = self.arm.group
            T = self.cell.scene.link_pose(arm.base_link).inverse() * pose
            ik = solve_ik(arm, T, seed=near, tip_link=self.geometry.eef_link, collision_free=False)
            if len(ik.solutions):
                target = ik.solutions[0]
        if target is not None:
            self.arm.set_joint_value_target(target)
        else:
            self.arm.set_pose_target(pose)
        t = time.perf_counter()
        plan = self.arm.plan(fix_start=True)  # fingers may rest against what they let go
        self._plan_s += time.perf_counter() - t
        if not plan.success or plan.trajectory is None:
            raise _Failed("move", plan.reason or "no plan")
        if not self.arm.execute(plan):
            raise _Failed("move", "execution failed")
        self._robot_s += plan.trajectory.duration

    def _move_to_pre(
        self, pose: Pose, approach: GripperTranslation, near: np.ndarray | None = None
    ) -> float:
        """Move to the start of an approach: ``desired_distance`` back from ``pose`` if the arm
        reaches there, else ``min_distance``; returns the distance used. ``near``: the arm's
        joints at ``pose`` (the branch the approach should follow), if known."""
        tried: list[str] = []
        for dist in dict.fromkeys((approach.desired_distance, approach.min_distance)):
            pre = Pose(pose.position - approach.vector(dist), pose.orientation)
            try:
                self._move_to(pre, near=near)
                return dist
            except _Stopped:
                raise
            except _Failed as f:
                tried.append(f"{dist:.3f} m back: {f.reason}")
            except RobocellError as exc:
                tried.append(f"{dist:.3f} m back: {exc}")
        raise _Failed("move", "; ".join(tried))

    def _line(self, stage: str, offset: np.ndarray, min_distance: float) -> None:
        self._check_stop()
        t = time.perf_counter()
        T = self.arm.get_current_pose()
        target = Pose(T.position + offset, T.orientation)
        cp = self.arm.compute_cartesian_path([target])
        self._plan_s += time.perf_counter() - t
        total = float(np.linalg.norm(offset))
        if cp.fraction * total < min_distance - 1e-6 or cp.fraction <= 0:
            raise _Failed(stage, f"straight line only {cp.fraction:.0%} possible: {cp.reason}")
        if not self.arm.execute(cp.trajectory):
            raise _Failed(stage, "execution failed")
        self._robot_s += cp.trajectory.duration

    def _retreat(self, offset: np.ndarray, min_distance: float, name: str) -> None:
        """The straight retreat, with the contacts the gripper and the object have at its start
        allowed for its duration: the surface the object leaves, the tray wall or the
        neighbour a finger rests against after letting go."""
        scene = self.cell.scene
        ours = {name, *self.finger_links}
        touching = [(a, b) for a, b in scene.colliding_pairs() if a in ours or b in ours]
        for a, b in touching:
            scene.allow_collision(a, b)
        try:
            self._line("retreat", offset, min_distance)
        finally:
            for a, b in touching:
                scene.allow_collision(a, b, False)

    # ------------------------------------------------------------------ pick
    def pick(self, name: str, grasps: list[Grasp]) -> ManipulationResult:
        """Pick object ``name`` with the first grasp (in quality order) that works."""
        cell, scene = self.cell, self.cell.scene
        if not isinstance(name, str) or name not in cell.object_names:
            raise GraspError(f"unknown object {name!r}; known: {', '.join(cell.object_names)}")
        grasps = _candidates(grasps, Grasp, "pick")
        if not grasps:
            return ManipulationResult(False, reason=f"no grasp candidates for {name!r}")
        self._plan_s = self._robot_s = 0.0
        self._stop.clear()
        result = ManipulationResult(False)
        padding = scene.object_padding(name)
        scene.set_object_padding(name, 0.0)  # the gripper goes right up to it
        try:
            self._pick(name, grasps, result)
        finally:
            scene.set_object_padding(name, padding)
        return self._finish(result, len(grasps), "grasps")

    def _pick(self, name: str, grasps: list[Grasp], result: ManipulationResult) -> None:
        cell, scene = self.cell, self.cell.scene
        start = cell.object_pose(name)
        for g in sorted(grasps, key=lambda x: -x.quality):
            moved = _moved(start, cell.object_pose(name))
            if moved:
                # the grasps were made for where it was: the caller makes new ones
                result.reason = f"{name!r} moved ({moved}) since its grasps were made"
                break
            try:
                cell.sync_scene()
                self._gripper(g.pre_grasp_posture)
                result.stages.append(StageResult(g.id, "open", True))
                dist = self._move_to_pre(g.pose, g.pre_grasp_approach, g.joint_positions)
                result.stages.append(StageResult(g.id, "move", True))
                scene.allow_collision(name, self.finger_links)
                # the approach ends at the grasp pose (its length is what may be shortened, as
                # MoveIt's, never its end): fingers closed short of it pinch with their tips
                self._line("approach", g.pre_grasp_approach.vector(dist), dist - 0.001)
                result.stages.append(StageResult(g.id, "approach", True))
                self._gripper(g.grasp_posture)
                if cell.world is not None and not cell.is_grasped(name):
                    raise _Failed("close", "the fingers closed but do not hold the object")
                result.stages.append(StageResult(g.id, "close", True))
                cell.sync_scene()
                self.arm.attach_object(name, touch_links=self.hand_links)
                before = cell.held_offset(name) if cell.world is not None else None
                self._retreat(
                    g.post_grasp_retreat.vector(), g.post_grasp_retreat.min_distance, name
                )
                if cell.world is not None:
                    if not cell.is_grasped(name):
                        raise _Failed("retreat", "the object dropped out of the gripper")
                    assert before is not None
                    if cell.has_slipped(name, before, 0.01):
                        raise _Failed("retreat", "the object slipped in the gripper")
                result.stages.append(StageResult(g.id, "retreat", True))
                result.success, result.candidate = True, g.id
                break
            except _Stopped as f:
                result.stages.append(StageResult(g.id, f.stage, False, f.reason))
                self._after_stop(name)
                break
            except _Failed as f:
                result.stages.append(StageResult(g.id, f.stage, False, f.reason))
                self._recover(name)
            except RobocellError as exc:
                result.stages.append(StageResult(g.id, "plan", False, str(exc)))
                self._recover(name)

    # ------------------------------------------------------------------ push
    def push(self, name: str, pushes: list[Push]) -> ManipulationResult:
        """Push object ``name`` with the first push (in quality order) that works: close the
        gripper, move above the push's start, come straight down beside the object, push in a
        straight line (the fingers may touch the object), lift up and back. A push that leaves
        the object where it was (under 2 mm and 1°) fails, and the next is tried. The result's
        reason says how far the object moved and turned. Physics only: in kinematic mode
        nothing moves what the gripper touches."""
        cell, scene = self.cell, self.cell.scene
        if not isinstance(name, str) or name not in cell.object_names:
            raise GraspError(f"unknown object {name!r}; known: {', '.join(cell.object_names)}")
        pushes = _candidates(pushes, Push, "push")
        if cell.world is None:
            raise GraspError("pushing needs physics: in kinematic mode objects do not move")
        if name in scene.attached_objects:
            raise GraspError(f"object {name!r} is held: place or release it first")
        self._plan_s = self._robot_s = 0.0
        self._stop.clear()
        result = ManipulationResult(False)
        if not pushes:
            result.reason = f"no push candidates for {name!r}"
            return result
        before = cell.object_pose(name)
        padding = scene.object_padding(name)
        scene.set_object_padding(name, 0.0)  # the fingers come down right beside it
        try:
            for p in sorted(pushes, key=lambda x: -x.quality):
                try:
                    cell.sync_scene()
                    self._gripper(self.geometry.closed_command)
                    result.stages.append(StageResult(p.id, "close", True))
                    above = Pose(
                        p.pose.position + np.array([0.0, 0.0, p.descent]), p.pose.orientation
                    )
                    self._move_to(above, near=p.joint_positions)
                    result.stages.append(StageResult(p.id, "move", True))
                    self._line("descend", np.array([0.0, 0.0, -p.descent]), p.descent)
                    result.stages.append(StageResult(p.id, "descend", True))
                    # once touched, the object moves ahead of the hand: where it was is no
                    # obstacle to the hand that follows (the push's start was checked clear)
                    scene.allow_collision(name, self.hand_links)
                    self._line("push", p.push.vector(), p.push.min_distance)
                    result.stages.append(StageResult(p.id, "push", True))
                    cell.sync_scene()
                    self._retreat(p.lift(), 0.5 * p.descent, name)
                    result.stages.append(StageResult(p.id, "retreat", True))
                    # at rest, away from the fingers: did it stay upright?
                    cell.world.step(100)
                    cell.sync_scene()
                    after = cell.object_pose(name)
                    if not _moved(before, after, 0.002, np.radians(1.0)):
                        # it passed beside the object (measured: one layout pushed the same
                        # air four times); the object is where it was, so the next may do
                        result.stages.append(
                            StageResult(p.id, "push", False, "the fingers did not move it")
                        )
                        continue
                    tilt = float(np.degrees(np.arccos(np.clip(after.rotation()[2, 2], -1.0, 1.0))))
                    if before.rotation()[2, 2] > 0.99 and tilt > 20.0:
                        result.stages.append(
                            StageResult(
                                p.id, "settle", False, f"the object tipped over ({tilt:.0f}°)"
                            )
                        )
                        result.reason = f"the push tipped {name!r} over ({tilt:.0f}°)"
                        break
                    result.success, result.candidate = True, p.id
                    break
                except _Stopped as f:
                    result.stages.append(StageResult(p.id, f.stage, False, f.reason))
                    self.cell.sync_scene()
                    break
                except _Failed as f:
                    result.stages.append(StageResult(p.id, f.stage, False, f.reason))
                    if f.stage != "move" and f.stage != "close":
                        break  # the gripper went down: the object may have moved
                except RobocellError as exc:
                    result.stages.append(StageResult(p.id, "plan", False, str(exc)))
                finally:
                    scene.allow_collision(name, self.hand_links, False)
        finally:
            scene.set_object_padding(name, padding)
            cell.sync_scene()
        moved = _moved(before, cell.object_pose(name), 0.0, 0.0)
        if result.success:
            result.reason = f"moved {moved}"
        return self._finish(result, len(pushes), "pushes")

    def release(self, name: str) -> None:
        """Let go of a held object where it is (open the gripper, detach it): after a place
        that failed, so that the next pick starts with an empty hand."""
        if not isinstance(name, str) or name not in self.cell.scene.attached_objects:
            raise GraspError(f"object {name!r} is not held")
        self._stop.clear()
        self.set_gripper(self.geometry.open_command)
        self.cell.scene.detach_object(name)
        if self.cell.world is None:
            self.cell.drop(name)
        self.cell.sync_scene()

    def _finish(self, result: ManipulationResult, n: int, what: str) -> ManipulationResult:
        """The times, and for a failure without a reason yet, its last failed stage."""
        if not result.success and not result.reason:
            last = result.failures()[-1] if result.failures() else None
            result.reason = (
                f"all {n} {what} failed; last: {last.stage} of {last.candidate}: {last.reason}"
                if last
                else f"no {what[:-1]} worked"
            )
        result.planning_time, result.robot_time = self._plan_s, self._robot_s
        return result

    def _after_stop(self, name: str) -> None:
        """After a stop: the robot holds where it is; the scene keeps the object attached only
        if it is really in the gripper."""
        scene = self.cell.scene
        held = name in scene.attached_objects
        if held and self.cell.world is not None and not self.cell.is_grasped(name):
            scene.detach_object(name)
            held = False
        self.cell.sync_scene()
        if not held:
            scene.allow_collision(name, self.finger_links, False)

    def _recover(self, name: str) -> None:
        """After a failed candidate: open the gripper, drop the object from the scene's hand,
        forbid the touches allowed for the attempt."""
        scene = self.cell.scene
        try:
            self.set_gripper(self.geometry.open_command)
        except RobocellError:
            pass
        if name in scene.attached_objects:
            scene.detach_object(name)
        self.cell.sync_scene()
        scene.allow_collision(name, self.finger_links, False)

    # ------------------------------------------------------------------ place
    def place(
        self, name: str, locations: list[PlaceLocation], settle_tolerance: float = 0.03
    ) -> ManipulationResult:
        """Place the held object ``name`` at the first location (in quality order) that
        works."""
        cell, scene = self.cell, self.cell.scene
        if not isinstance(name, str) or name not in scene.attached_objects:
            raise GraspError(
                f"object {name!r} is not held; held: {', '.join(scene.attached_objects) or 'none'}"
            )
        locations = _candidates(locations, PlaceLocation, "place")
        self._plan_s = self._robot_s = 0.0
        self._stop.clear()
        result = ManipulationResult(False)
        for loc in sorted(locations, key=lambda x: -x.quality):
            try:
                self.arm.set_max_acceleration_scaling_factor(self.carry_acceleration)
                try:
                    dist = self._move_to_pre(loc.pose, loc.pre_place_approach)
                finally:
                    self.arm.set_max_acceleration_scaling_factor(1.0)
                if cell.world is not None and not cell.is_grasped(name):
                    scene.detach_object(name)  # it lies where it fell: nothing is held
                    cell.sync_scene()
                    raise _Failed("move", "the object dropped out of the gripper on the way")
                result.stages.append(StageResult(loc.id, "move", True))
                # the object goes right down onto its place: no padding on the way down
                padding = scene.object_padding(name)
                scene.set_object_padding(name, 0.0)
                try:
                    # a place may stop short (at least the minimum distance down): the object
                    # is then let go a little higher, and the settle check sees where it lands
                    self._line(
                        "approach",
                        loc.pre_place_approach.vector(dist),
                        loc.pre_place_approach.min_distance,
                    )
                finally:
                    scene.set_object_padding(name, padding)
                result.stages.append(StageResult(loc.id, "approach", True))
                self._gripper(loc.post_place_posture)
                cell.sync_scene()
                scene.detach_object(name)
                if cell.world is None:
                    scene.move_object(name, loc.object_pose)
                    cell.drop(name)  # released above the surface: it falls onto it
                result.stages.append(StageResult(loc.id, "release", True))
                scene.allow_collision(name, self.finger_links)
                try:
                    self._retreat(
                        loc.post_place_retreat.vector(), loc.post_place_retreat.min_distance, name
                    )
                finally:
                    scene.allow_collision(name, self.finger_links, False)
                result.stages.append(StageResult(loc.id, "retreat", True))
                if cell.world is not None:
                    cell.world.step(250)
                    p = cell.world.object_pose(name).position
                    off = float(np.linalg.norm(p[:2] - loc.object_pose.position[:2]))
                    if off > settle_tolerance:
                        result.stages.append(
                            StageResult(
                                loc.id,
                                "settle",
                                False,
                                f"object rests {off * 1e3:.0f} mm from its place",
                            )
                        )
                        cell.sync_scene()
                        result.reason = "the object did not stay where it was put"
                        break
                    cell.sync_scene()
                result.success, result.candidate = True, loc.id
                break
            except _Failed as f:
                result.stages.append(StageResult(loc.id, f.stage, False, f.reason))
                if isinstance(f, _Stopped):
                    self._after_stop(name)
                    break
                if name not in scene.attached_objects:
                    break  # released: no other location can be tried with it
            except RobocellError as exc:
                result.stages.append(StageResult(loc.id, "plan", False, str(exc)))
        return self._finish(result, len(locations), "places")


def _candidates(items: object, kind: type, what: str) -> list[Any]:
    """``items`` as a list of ``kind`` (a list or tuple of them), or a GraspError."""
    if not isinstance(items, list | tuple) or not all(isinstance(x, kind) for x in items):
        raise GraspError(f"{what} needs a list of {kind.__name__} candidates, got {items!r}")
    return list(items)
