import numpy as np
import pytest

from robocell.geometry import Box, Cylinder, Mesh, Sphere, triangulate
from robocell.scene.spheres import (
    distance_grid,
    shape_tree,
    signed_distance,
    winding_and_distance,
)


def _leaves_of(tree, i):
    if tree.left[i] < 0:
        return [i]
    return _leaves_of(tree, tree.left[i]) + _leaves_of(tree, tree.right[i])


def _covered(tree, P):
    L = tree.leaves
    d = np.linalg.norm(P[:, None, :] - L[None, :, :3], axis=2) - L[None, :, 3]
    return d.min(axis=1) <= 1e-9


@pytest.mark.parametrize("shape", [Box((0.2, 0.1, 0.05)), Cylinder(0.04, 0.2), Sphere(0.05)])
def test_primitive_leaves_cover_the_solid_and_inner_spheres_are_inside(shape):
    tree = shape_tree(shape)
    rng = np.random.default_rng(0)
    P = rng.uniform(-0.11, 0.11, (20000, 3))
    inside = signed_distance(shape, P) <= 0
    assert _covered(tree, P[inside]).all()
    # inner spheres lie inside the solid
    assert len(tree.inner) > 0
    assert np.all(signed_distance(shape, tree.inner[:, :3]) <= -tree.inner[:, 3] + 1e-9)


def test_mesh_leaves_cover_the_surface():
    V, F = triangulate(Cylinder(0.05, 0.3), segments=40)
    T = np.eye(4)
    T[:3, 3] = (0.1, 0, 0)
    tree = shape_tree(Mesh(V, F), T)
    rng = np.random.default_rng(1)
    tri = V[F] + T[:3, 3]
    u = rng.random((5000, 2))
    flip = u.sum(axis=1) > 1
    u[flip] = 1 - u[flip]
    k = rng.integers(0, len(F), 5000)
    P = tri[k, 0] + u[:, :1] * (tri[k, 1] - tri[k, 0]) + u[:, 1:] * (tri[k, 2] - tri[k, 0])
    assert _covered(tree, P).all()
    assert len(tree.inner) > 0  # a closed mesh has spheres inside
    assert np.all(
        np.hypot(tree.inner[:, 0] - 0.1, tree.inner[:, 1]) + tree.inner[:, 3]
        <= 0.05 / np.cos(np.pi / 40) + 1e-9
    )


def test_every_node_contains_the_leaves_below_it():
    tree = shape_tree(Box((0.1, 0.2, 0.05)))
    for i in np.flatnonzero(tree.left >= 0)[:300]:
        lv = _leaves_of(tree, int(i))
        n = tree.nodes[i]
        assert np.all(
            np.linalg.norm(tree.nodes[lv, :3] - n[:3], axis=1) + tree.nodes[lv, 3] <= n[3] + 1e-9
        )


def _grid_bounds(grid, P):
    """grid(g) − |x − g| at the nearest grid point g, and the box bound, for points P."""
    idx = np.clip(np.round((P - grid.origin) / grid.h), 0, grid.dims - 1).astype(int)
    g = grid.origin + idx * grid.h
    flat = (idx[:, 0] * grid.dims[1] + idx[:, 1]) * grid.dims[2] + idx[:, 2]
    bound = grid.values[flat] - np.linalg.norm(P - g, axis=1)
    box = np.linalg.norm(np.maximum(np.maximum(grid.box[0] - P, P - grid.box[1]), 0), axis=1)
    return bound, box, np.abs(P - g).max(axis=1)


def test_distance_grid_is_a_lower_bound_of_the_distance_to_the_mesh_surface():
    """At any point x and its nearest grid point g, grid(g) − |x − g| ≤ the distance from x to
    the mesh's triangles (what coal tests); far outside, the box bound holds. Near the body the
    bound is within the grid's diagonal of the truth (leaf spheres alone fell a leaf radius
    further short)."""
    V, F = triangulate(Cylinder(0.05, 0.3), segments=40)
    tree = shape_tree(Mesh(V, F))
    grid = distance_grid(tree)
    rng = np.random.default_rng(2)
    span = (grid.dims - 1) * grid.h
    P = grid.origin + rng.uniform(-0.2, 1.2, (3000, 3)) * span
    bound, box, off = _grid_bounds(grid, P)
    true = winding_and_distance(P, tree.tris)[1]
    assert np.all(np.maximum(bound, box) <= true + 1e-12)
    near = (true < 0.02) & (off < 0.5 * grid.h + 1e-12)
    assert near.sum() > 50
    assert np.all(true[near] - bound[near] <= np.sqrt(3) * grid.h + 1e-6)
    leaf_radius = tree.leaves[:, 3].max()
    assert np.median(true[near] - bound[near]) < 0.5 * leaf_radius


def test_distance_grid_of_a_primitive_bounds_the_distance_to_its_leaves():
    """A primitive's leaves cover its solid: the grid bounds the distance to them."""
    tree = shape_tree(Box((0.1, 0.2, 0.05)))
    grid = distance_grid(tree)
    rng = np.random.default_rng(5)
    P = grid.origin + rng.uniform(-0.2, 1.2, (2000, 3)) * (grid.dims - 1) * grid.h
    bound, box, _ = _grid_bounds(grid, P)
    L = tree.leaves
    true = np.maximum(
        (np.linalg.norm(P[:, None, :] - L[None, :, :3], axis=2) - L[None, :, 3]).min(axis=1), 0
    )
    assert np.all(np.maximum(bound, box) <= true + 1e-12)
    assert (true < 0.01).sum() > 20


def test_every_point_of_a_triangle_is_in_a_leaf_that_lists_the_triangle():
    """What makes the kernel's triangle tests exact: where two surfaces cross, a leaf of each
    covers the crossing point and lists the triangle it is on."""
    V, F = triangulate(Cylinder(0.05, 0.3), segments=24)
    T = np.eye(4)
    T[:3, 3] = (0.02, -0.01, 0.1)
    tree = shape_tree(Mesh(V, F), T)
    assert tree.meshes_only and len(tree.tris) == len(F)
    assert np.allclose(tree.tris, V[F] + T[:3, 3])
    rng = np.random.default_rng(4)
    leaf_nodes = np.flatnonzero(tree.left < 0)
    for f in rng.choice(len(F), 30, replace=False):
        u = rng.random((40, 2))
        u[u.sum(axis=1) > 1] = 1 - u[u.sum(axis=1) > 1]
        a, b, c = tree.tris[f]
        P = a + u[:, :1] * (b - a) + u[:, 1:] * (c - a)
        for p in P:
            inside = leaf_nodes[
                np.linalg.norm(tree.nodes[leaf_nodes, :3] - p, axis=1)
                <= tree.nodes[leaf_nodes, 3] + 1e-12
            ]
            assert any(f in tree.tri_ids[tree.tri_start[m] : tree.tri_start[m + 1]] for m in inside)
    # a primitive's leaves list no triangles
    box = shape_tree(Box((0.1, 0.2, 0.05)))
    assert not box.meshes_only and box.tri_start[-1] == 0


def test_body_trees_are_kept_in_memory_by_content():
    """A held object's tree is built or loaded once per process: the same shapes give the same
    tree, other shapes or poses another one."""
    from robocell.scene.spheres import body_tree

    T = np.eye(4)
    a = body_tree([(Box((0.05, 0.04, 0.03)), T)])
    assert body_tree([(Box((0.05, 0.04, 0.03)), T.copy())]) is a
    assert body_tree([(Box((0.05, 0.04, 0.031)), T)]) is not a
    moved = T.copy()
    moved[0, 3] = 0.01
    b = body_tree([(Box((0.05, 0.04, 0.03)), moved)])
    assert b is not a and np.allclose(b.nodes[0, 0], a.nodes[0, 0] + 0.01)
