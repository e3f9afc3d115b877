import math

import numpy as np
import pytest

from robocell.errors import GeometryError
from robocell.geometry import Box, Cylinder, Mesh, Sphere, triangulate


@pytest.mark.parametrize(
    "make",
    [
        lambda: Box((1, 0, 1)),
        lambda: Box((1, -2, 1)),
        lambda: Cylinder(0.1, 0),
        lambda: Cylinder(math.nan, 1),
        lambda: Sphere(-1),
        lambda: Box((1, 1)),
    ],
)
def test_non_positive_or_malformed_sizes_raise(make):
    with pytest.raises(GeometryError):
        make()


def test_mesh_validates_indices_and_reads_files(tmp_path):
    with pytest.raises(GeometryError, match="out of range"):
        Mesh(np.zeros((3, 3)), np.array([[0, 1, 5]]))
    with pytest.raises(GeometryError, match="not found"):
        Mesh.from_file(tmp_path / "missing.stl")
    stl = tmp_path / "tri.obj"
    stl.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    m = Mesh.from_file(stl, scale=(2, 2, 2))
    assert m.vertices.shape == (4, 3) and m.triangles.shape == (4, 3)
    assert np.isclose(m.vertices.max(), 2.0)


@pytest.mark.parametrize("shape", [Box((0.2, 0.1, 0.05)), Cylinder(0.05, 0.3), Sphere(0.07)])
def test_triangulation_contains_the_shape(shape):
    """Points on the true surface lie inside the (circumscribed) triangulation's hull."""
    V, F = triangulate(shape)
    rng = np.random.default_rng(1)
    # sample the true surface
    if isinstance(shape, Sphere):
        d = rng.normal(size=(500, 3))
        P = shape.radius * d / np.linalg.norm(d, axis=1, keepdims=True)
    elif isinstance(shape, Cylinder):
        a = rng.uniform(0, 2 * np.pi, 500)
        P = np.c_[shape.radius * np.cos(a), shape.radius * np.sin(a), rng.uniform(-0.15, 0.15, 500)]
    else:
        P = rng.uniform(-0.5, 0.5, (500, 3)) * np.array(shape.size)
    # inside test: for a convex closed mesh, every outward face plane has the point behind it
    tri = V[F]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n *= np.sign(np.einsum("ij,ij->i", n, tri[:, 0]))[:, None]  # orient outward (centred shapes)
    side = np.einsum("fj,pfj->pf", n, P[:, None, :] - tri[None, :, 0])
    assert np.all(side <= 1e-12)
