"""Primitive shapes and meshes, in their own frame.

As MoveIt's shape_msgs: a :class:`Box` is centred on its frame with full extents ``size``; a
:class:`Cylinder` is centred with its axis along z; a :class:`Sphere` is centred; a :class:`Mesh` is
a triangle mesh read from STL, OBJ or DAE (through coal's loader) or given as arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robocell.errors import GeometryError
from robocell.geometry.pose import as_vector


def _positive(value: float, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise GeometryError(f"{name} must be a number, got {value!r}") from exc
    if not math.isfinite(v) or v <= 0.0:
        raise GeometryError(f"{name} must be positive and finite, got {value!r}")
    return v


@dataclass(frozen=True)
class Box:
    """A box centred on its frame; ``size`` = full extents (x, y, z) in [m]."""

    size: tuple[float, float, float]

    def __post_init__(self) -> None:
        s = as_vector(self.size, 3, "box size")
        object.__setattr__(self, "size", tuple(_positive(v, "box size") for v in s))

    @property
    def kind(self) -> str:
        return "box"

    def bounding_radius(self) -> float:
        return 0.5 * float(np.linalg.norm(self.size))


@dataclass(frozen=True)
class Cylinder:
    """A cylinder centred on its frame, axis z; ``radius`` and ``length`` (full height) in [m]."""

    radius: float
    length: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _positive(self.radius, "cylinder radius"))
        object.__setattr__(self, "length", _positive(self.length, "cylinder length"))

    @property
    def kind(self) -> str:
        return "cylinder"

    def bounding_radius(self) -> float:
        return math.hypot(self.radius, 0.5 * self.length)


@dataclass(frozen=True)
class Sphere:
    """A sphere centred on its frame; ``radius`` in [m]."""

    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _positive(self.radius, "sphere radius"))

    @property
    def kind(self) -> str:
        return "sphere"

    def bounding_radius(self) -> float:
        return self.radius


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh: ``vertices`` (V, 3) in [m] (already scaled), ``triangles`` (F, 3) indices.

    ``path`` records where it was read from (kept for export); build one with :meth:`from_file`.
    """

    vertices: NDArray[np.float64]
    triangles: NDArray[np.int64]
    path: str | None = None
    scale: tuple[float, float, float] = field(default=(1.0, 1.0, 1.0))

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=float)
        t = np.asarray(self.triangles, dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3 or len(v) < 3:
            raise GeometryError(f"mesh vertices must be (V>=3, 3), got {v.shape}")
        if t.ndim != 2 or t.shape[1] != 3 or len(t) < 1:
            raise GeometryError(f"mesh triangles must be (F>=1, 3), got {t.shape}")
        if t.min() < 0 or t.max() >= len(v):
            raise GeometryError(f"mesh triangle index out of range 0..{len(v) - 1}")
        if not np.all(np.isfinite(v)):
            raise GeometryError("mesh vertices contain NaN or infinity")
        v.flags.writeable = False
        t.flags.writeable = False
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "triangles", t)

    @property
    def kind(self) -> str:
        return "mesh"

    @classmethod
    def from_file(cls, path: str | Path, scale: ArrayLike = (1.0, 1.0, 1.0)) -> Mesh:
        """Read an STL, OBJ or DAE file (anything assimp reads), scaled per axis."""
        import coal

        if not isinstance(path, (str, Path)):
            raise GeometryError(f"a mesh file's path must be a str or a Path, got {path!r}")
        p = Path(path)
        if not p.is_file():
            raise GeometryError(f"mesh file not found: {str(p)!r}")
        s = as_vector(scale, 3, "mesh scale")
        try:
            bvh = coal.MeshLoader().load(str(p), s)
        except Exception as exc:  # assimp's errors are plain RuntimeErrors
            raise GeometryError(f"cannot read mesh {str(p)!r}: {exc}") from exc
        verts, tris = bvh_arrays(bvh)
        return cls(verts, tris, str(p), (float(s[0]), float(s[1]), float(s[2])))

    def bounding_radius(self) -> float:
        return float(np.max(np.linalg.norm(self.vertices, axis=1)))


Shape = Box | Cylinder | Sphere | Mesh
SHAPE_KINDS = ("box", "cylinder", "sphere", "mesh")


def bvh_arrays(bvh: Any) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Vertices (V, 3) and triangles (F, 3) of a coal BVH model."""
    verts: NDArray[np.float64] = np.array(bvh.vertices(), dtype=np.float64)
    n = bvh.num_tris
    tris = np.empty((n, 3), dtype=np.int64)
    for i in range(n):
        t = bvh.tri_indices(i)
        tris[i] = (t[0], t[1], t[2])
    return verts, tris


def triangulate(shape: Shape, segments: int = 24) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """A closed triangle mesh that *contains* ``shape`` (circumscribed for curved shapes).

    Used to cover a shape with spheres: covering this mesh covers the true shape.
    """
    if isinstance(shape, Mesh):
        return np.asarray(shape.vertices), np.asarray(shape.triangles)
    if isinstance(shape, Box):
        hx, hy, hz = (0.5 * v for v in shape.size)
        v = np.array(
            [[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
        )
        faces = [
            [0, 1, 3],
            [0, 3, 2],
            [4, 6, 7],
            [4, 7, 5],
            [0, 4, 5],
            [0, 5, 1],
            [2, 3, 7],
            [2, 7, 6],
            [0, 2, 6],
            [0, 6, 4],
            [1, 5, 7],
            [1, 7, 3],
        ]
        return v, np.array(faces, dtype=np.int64)
    if isinstance(shape, Cylinder):
        r = shape.radius / math.cos(math.pi / segments)  # the polygon's edges touch the circle
        a = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
        ring = np.stack([r * np.cos(a), r * np.sin(a)], axis=1)
        h = 0.5 * shape.length
        v = np.vstack(
            [
                np.c_[ring, -h * np.ones(segments)],
                np.c_[ring, h * np.ones(segments)],
                [[0, 0, -h], [0, 0, h]],
            ]
        )
        faces = []
        for i in range(segments):
            j = (i + 1) % segments
            faces += [[i, j, segments + j], [i, segments + j, segments + i]]
            faces += [[2 * segments, j, i], [2 * segments + 1, segments + i, segments + j]]
        return v, np.array(faces, dtype=np.int64)
    if isinstance(shape, Sphere):
        # an icosahedron scaled so that its faces lie outside the sphere
        t = (1 + math.sqrt(5)) / 2
        v = np.array(
            [
                [-1, t, 0],
                [1, t, 0],
                [-1, -t, 0],
                [1, -t, 0],
                [0, -1, t],
                [0, 1, t],
                [0, -1, -t],
                [0, 1, -t],
                [t, 0, -1],
                [t, 0, 1],
                [-t, 0, -1],
                [-t, 0, 1],
            ],
            float,
        )
        f = np.array(
            [
                [0, 11, 5],
                [0, 5, 1],
                [0, 1, 7],
                [0, 7, 10],
                [0, 10, 11],
                [1, 5, 9],
                [5, 11, 4],
                [11, 10, 2],
                [10, 7, 6],
                [7, 1, 8],
                [3, 9, 4],
                [3, 4, 2],
                [3, 2, 6],
                [3, 6, 8],
                [3, 8, 9],
                [4, 9, 5],
                [2, 4, 11],
                [6, 2, 10],
                [8, 6, 7],
                [9, 8, 1],
            ]
        )
        v /= np.linalg.norm(v[0])
        inradius = np.linalg.norm(v[f[0]].mean(axis=0))
        return v * shape.radius / inradius, f.astype(np.int64)
    raise GeometryError(f"unknown shape {shape!r}; known kinds: {', '.join(SHAPE_KINDS)}")


def padded(shape: Shape, padding: float) -> Shape:
    """A primitive grown by ``padding`` [m] on every side (a box's size by 2·padding, a
    cylinder's radius by padding and length by 2·padding, a sphere's radius by padding)."""
    if padding == 0:
        return shape
    if isinstance(shape, Box):
        return Box(tuple(v + 2 * padding for v in shape.size))  # type: ignore[arg-type]
    if isinstance(shape, Cylinder):
        return Cylinder(shape.radius + padding, shape.length + 2 * padding)
    if isinstance(shape, Sphere):
        return Sphere(shape.radius + padding)
    raise GeometryError(f"only boxes, cylinders and spheres can be padded, not a {shape.kind}")
