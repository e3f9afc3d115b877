"""Self-collision tables of link pairs one or two joints apart, and of a link against a rigid
cluster (a hand) up to three joints below it: which get one, and that a cell called FREE or HIT
is so for coal everywhere in it, including at its corners next to the cells the table leaves
to the kernel."""

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
    # unless three are allowed (a link against a hand)
    chain = table_chain(mbm_ur5, "forearm_link", "wrist_3_link", moving, max_joints=3)
    assert chain is not None
    wrist = ["wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
    assert [names[v] for v in chain.variables] == wrist
    assert table_chain(mbm_ur5, "upper_arm_link", "wrist_3_link", moving, max_joints=3) is None
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


def _cells(checker):
    """The checker's table cells, one per entry (the kernel's array holds four to a byte,
    the first in the lowest bits)."""
    packed = checker._tables[4]
    return np.stack([(packed >> shift) & 3 for shift in (0, 2, 4, 6)], axis=1).ravel()


def _tables(checker):
    """(pairs, variables, n, offset, size) of every table: a self pair's, or a pair group's
    (a body against the members of a rigid cluster: the table is over all its pairs)."""
    index, variables, cells, offsets = checker._tables[:4]
    owners = [([pair], index[k]) for k, pair in enumerate(checker.self_pairs)]
    owners += [
        ([checker.self_pairs[k] for k in g.pairs], checker._tables[5][gi])
        for gi, g in enumerate(checker._groups)
    ]
    out = []
    for pairs, t in owners:
        if t >= 0:
            n_vars = int((variables[t] >= 0).sum())
            n = cells[t]
            out.append((pairs, variables[t][:n_vars], n, offsets[t], n**n_vars))
    return out


@pytest.mark.parametrize(
    ("robot", "group_name"),
    [("mbm_ur5", "manipulator"), ("irb120", "arm"), ("mbm_panda", "panda_arm")],
)
def test_table_cells_agree_with_coal(robot, group_name, request):
    model = request.getfixturevalue(robot)
    group = model.group(group_name)
    scene = PlanningScene(model)
    checker = scene.checker(group)
    tables = _tables(checker)
    assert tables, "no pair got a table"
    values = _cells(checker)
    rng = np.random.default_rng(7)
    seen = {TABLE_FREE: 0, TABLE_HIT: 0}
    for pairs, variables, n, off, size in tables:
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
            hit = any(checker._collide(T, pair, False) for pair in pairs)
            assert hit == (v == TABLE_HIT), (pairs, ix, v)
            seen[v] += 1
    assert seen[TABLE_FREE] > 50
    # the UR5's forearm against its hand (12 pairs): one table over the three wrist angles
    if robot == "mbm_ur5":
        assert any(len(pairs) == 12 and len(v) == 3 for pairs, v, *_ in tables)


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
    cells = _cells(checker)
    decided = []
    for _pairs, variables, n, off, _size in _tables(checker):
        full = np.tile(base, (len(qs), 1))
        full[:, group.indices] = qs
        x = full[:, variables] / (2 * np.pi)
        ix = np.minimum(((x - np.floor(x)) * n).astype(int), n - 1)
        flat = np.ravel_multi_index(tuple(ix.T), (n,) * len(variables))
        decided.append(np.mean(cells[off + flat] != TABLE_CHECK))
    assert np.mean(decided) > 0.85


def test_cells_settled_exactly_agree_with_coal(mbm_ur5):
    """The UR5's forearm and wrist 2 come within a few mm of each other over a wide band of
    the wrist angles, where spheres settle nothing (7.4 % of the table, none of it HIT): cells
    are settled there by coal's distance and by the wrist's surface crossing the forearm's.
    Random points inside such cells agree with coal, and little of the band is left."""
    group = mbm_ur5.group("manipulator")
    checker = PlanningScene(mbm_ur5).checker(group)
    names = mbm_ur5.variable_names
    values = _cells(checker)
    wrist = ["wrist_1_joint", "wrist_2_joint"]
    pairs, variables, n, off, size = next(
        t for t in _tables(checker) if [names[v] for v in t[1]] == wrist
    )
    cells = values[off : off + size].reshape(n, n)
    assert (cells == TABLE_CHECK).mean() < 0.025
    rng = np.random.default_rng(11)
    check = cells == TABLE_CHECK
    near = np.zeros_like(check)
    for ax in range(2):
        for s in (-3, -1, 1, 3):
            near |= np.roll(check, s, ax)
    for verdict in (TABLE_HIT, TABLE_FREE):
        candidates = np.argwhere((cells == verdict) & near)
        assert len(candidates) > 100
        for ix in candidates[rng.integers(len(candidates), size=80)]:
            full = checker.base_positions.copy()
            full[variables] = (ix + rng.random(2)) * (2 * np.pi / n)
            T = checker._link_poses(full)
            assert checker._collide(T, pairs[0], False) == (verdict == TABLE_HIT), (ix, verdict)
