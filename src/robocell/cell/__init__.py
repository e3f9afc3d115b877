"""Cells and the user-facing MoveGroup."""

from robocell.cell.move_group import CartesianPlan, MoveGroup

__all__ = ["CartesianPlan", "MoveGroup"]
