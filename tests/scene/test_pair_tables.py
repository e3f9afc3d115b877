"""Self-collision tables of link pairs one or two joints apart: which pairs get one, and that a
cell called FREE or HIT is so for coal everywhere in it, including at its corners next to the
cells the table leaves to the kernel."""

import numpy as np
import pytest

from robocell.scene import PlanningScene
from robocell.scene.pair_tables import TABLE_CHECK, TABLE_FREE, TABLE_HIT, table_chain


def test_chains_of_the_ur5(mbm_ur5):
    moving = {int(i) for i in mbm_ur5.group("manipulator").indices}
    names = mbm_ur5.variable_names
    chain = table_chain(mbm_ur5, "base_link", "upper_arm_link", moving)
    assert chain is not None
    assert [names[v] for v in chain.variables] == ["shoulder_pan_joint", "shoulder_lift_joint"]
    assert mbm_ur5.tree.link_names[chain.upper] == "base_link"
    # either order of the pair
    swapped = table_chain(mbm_ur5, "upper_arm_link", "base_link", moving)
    assert swapped is not None and swapped.variables == chain.variables
    chain = table_chain(mbm_ur5, "wrist_2_link", "fts_robotside", moving)
    assert chain is not None and [names[v] for v in chain.variables] == ["wrist_3_joint"]
    # three joints apart, or joined only through a common ancestor: no table
    assert table_chain(mbm_ur5, "base_link", "forearm_link", moving) is None
    assert (
        table_chain(mbm_ur5, "robotiq_85_left_finger_link", "robotiq_85_right_finger_link", moving)
        is None
    )
    # joints the checker does not move keep their values: the table is over the others
    pan = names.index("shoulder_pan_joint")
    chain = table_chain(mbm_ur5, "base_link", "upper_arm_link", {pan})
    assert chain is not None and chain.variables == (pan,)
    assert [names[v] for v in chain.fixed] == ["shoulder_lift_joint"]
    assert table_chain(mbm_ur5, "base_link", "upper_arm_link", set()) is None


def _tables(checker):
    """(pair, PairTable) of every self pair that has one."""
    index = checker._tables[0]
    out = []
    for k, (i, j) in enumerate(checker.self_pairs):
        if index[k] >= 0:
            n_vars = int((checker._tables[1][index[k]] >= 0).sum())
            off, n = checker._tables[3][index[k]], checker._tables[2][index[k]]
            size = n**n_vars
            out.append(((i, j), checker._tables[1][index[k]][:n_vars], n, off, size))
    return out


@pytest.mark.parametrize(("robot", "group_name"), [("mbm_ur5", "manipulator"), ("irb120", "arm")])
def test_table_cells_agree_with_coal(robot, group_name, request):
    model = request.getfixturevalue(robot)
    group = model.group(group_name)
    scene = PlanningScene(model)
    checker = scene.checker(group)
    tables = _tables(checker)
    assert tables, "no pair got a table"
    values = checker._tables[4]
    rng = np.random.default_rng(7)
    seen = {TABLE_FREE: 0, TABLE_HIT: 0}
    for pair, variables, n, off, size in tables:
        cells = values[off : off + size].reshape((n,) * len(variables))
        # cells the table decides next to cells it leaves to the kernel: the margin's edge
        check = cells == TABLE_CHECK
        edge = np.zeros_like(check)
        for ax in range(cells.ndim):
            edge |= np.roll(check, 1, ax) | np.roll(check, -1, ax)
        candidates = np.argwhere(edge & ~check)
        if len(candidates) == 0:
            candidates = np.argwhere(~check)
        picks = candidates[rng.integers(len(candidates), size=min(60, len(candidates)))]
        h = 2 * np.pi / n
        for ix in picks:
            v = int(cells[tuple(ix)])
            # a corner of the cell (a hair inside), and its wraps by 2π
            corner = (ix + rng.choice([1e-9, 1 - 1e-9], size=len(ix))) * h
            corner += 2 * np.pi * rng.integers(-1, 1, size=len(ix))
            full = checker.base_positions.copy()
            full[group.indices] = np.clip(group.random(rng, 1)[0], group.lower, group.upper)
            full[variables] = corner
            T = checker._link_poses(full)
            assert checker._collide(T, pair, False) == (v == TABLE_HIT), (pair, ix, v)
            seen[v] += 1
    assert seen[TABLE_FREE] > 50


def test_tables_match_the_exact_check_on_random_states(mbm_ur5):
    """Random states: the kernel with its tables agrees with the exact check, and the tables
    settle most of the pairs they cover."""
    group = mbm_ur5.group("manipulator")
    checker = PlanningScene(mbm_ur5).checker(group)
    qs = group.random(np.random.default_rng(3), 3000)
    fast, exact = checker.check(qs), checker.check_exact(qs)
    assert not np.any(~fast & exact)
    assert 0.05 < exact.mean() < 0.95
    base = checker.base_positions
    decided = []
    for _pair, variables, n, off, _size in _tables(checker):
        full = np.tile(base, (len(qs), 1))
        full[:, group.indices] = qs
        x = full[:, variables] / (2 * np.pi)
        ix = np.minimum(((x - np.floor(x)) * n).astype(int), n - 1)
        flat = ix[:, 0] if len(variables) == 1 else ix[:, 0] * n + ix[:, 1]
        decided.append(np.mean(checker._tables[4][off + flat] != TABLE_CHECK))
    assert np.mean(decided) > 0.85
