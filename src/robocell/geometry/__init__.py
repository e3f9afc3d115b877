"""Poses, rotations, conventions and primitive shapes."""

from robocell.geometry.pose import (
    Pose,
    invert_transform,
    make_transform,
    matrix_to_quat,
    matrix_to_rpy,
    quat_to_matrix,
    rotation_error,
    rpy_to_matrix,
)
from robocell.geometry.shapes import SHAPE_KINDS, Box, Cylinder, Mesh, Shape, Sphere, triangulate

__all__ = [
    "SHAPE_KINDS",
    "Box",
    "Cylinder",
    "Mesh",
    "Pose",
    "Shape",
    "Sphere",
    "invert_transform",
    "make_transform",
    "matrix_to_quat",
    "matrix_to_rpy",
    "quat_to_matrix",
    "rotation_error",
    "rpy_to_matrix",
    "triangulate",
]
