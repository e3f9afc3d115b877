"""Cells (one file: robot, fixtures, objects, targets, cameras → planning scene and physics
world) and the user-facing MoveGroup."""

from robocell.cell.cell import Cell
from robocell.cell.cell_file import CellSpec, bundled_cells, load_cell_file
from robocell.cell.move_group import CartesianPlan, MoveGroup

__all__ = ["CartesianPlan", "Cell", "CellSpec", "MoveGroup", "bundled_cells", "load_cell_file"]
