import json

import pytest

from robocell.apps import demo
from robocell.apps.cli import main


def test_info_self_check_passes(capsys):
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert "irb120_robotiq85" in out and "ur5e_gripper" in out
    assert "self-check: PASS (2/2 robots, 1/1 cells)" in out
    assert "sorting: ok: loaded" in out


def test_no_command_prints_help(capsys):
    assert main([]) == 2
    assert "info" in capsys.readouterr().out


def test_demo_sorts_layout_0_in_physics(capsys, monkeypatch, tmp_path):
    """The main job: every object of the seed layout ends in its tray (exit status 0)."""
    (tmp_path / "demo-ran").touch()  # not the first run: no notice
    monkeypatch.setattr(demo, "first_run_marker", lambda: tmp_path / "demo-ran")
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert "8/8 objects in their trays" in out
    assert out.count("in its tray") == 8
    assert "first run" not in out


def test_demo_sorts_layout_0_in_kinematic_mode_by_shape(capsys, monkeypatch, tmp_path):
    """Demo mode (no physics): the same solution puts every object in its shape's tray. On a
    first run the demo says first that it compiles, then marks the cache as run."""
    marker = tmp_path / "cache" / "demo-ran"
    monkeypatch.setattr(demo, "first_run_marker", lambda: marker)
    assert main(["demo", "--mode", "kinematic", "--by", "shape"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[1].startswith("first run: robocell compiles its kernels")
    assert marker.exists()
    assert "8/8 objects in their trays" in out
    for name in ("yellow_box", "red_box", "blue_box"):
        assert any(line.startswith(name) and "red_tray" in line for line in out.splitlines())


def test_bench_planning_names_an_unknown_baseline(capsys):
    assert main(["bench", "planning", "--limit", "1", "--baseline", "ompl,moveit"]) == 1
    assert "unknown baseline 'moveit'; known: ompl, ompl-kernel" in capsys.readouterr().err


@pytest.mark.parametrize(
    "args, words",
    [
        (
            ["--robots", "panda", "--sets", "tabel_pick"],
            "unknown problem set of panda 'tabel_pick'",
        ),
        (["--robots", "ur6"], "unknown robot 'ur6'; known: panda, ur5"),
        (["--robots", "panda", "--sets", "table_pick", "--limit", "-1"], "--limit"),
        (["--robots", "panda", "--sets", "table_pick", "--timeout", "0"], "--timeout"),
        (["--robots", "panda", "--sets", "table_pick", "--runs", "0"], "--runs"),
        (["--robots", "panda", "--sets", "table_pick", "--busy", "-1"], "--busy"),
    ],
)
def test_bench_planning_names_an_unknown_robot_or_set_and_a_bad_limit(capsys, args, words):
    """Before, an unknown set printed a row of zeros and exited 0, an unknown robot named a
    missing URDF file, and --limit -1 ran all problems but the last."""
    assert main(["bench", "planning", *args]) == 1
    assert words in capsys.readouterr().err


def test_bench_planning_runs_plan_each_problem_with_seeds_of_their_own(tmp_path, capsys):
    """--runs 2: each problem planned twice (seeds --seed + problem + 1000 · run), the row's
    figures over both plans."""
    out = tmp_path / "bench.json"
    args = ["--robots", "panda", "--sets", "table_pick", "--limit", "2", "--runs", "2"]
    assert main(["bench", "planning", *args, "--seed", "5", "--json", str(out)]) == 0
    assert "2 runs per problem" in capsys.readouterr().out
    (row,) = json.loads(out.read_text())
    assert (row["problems"], row["valid"], row["solved"], row["runs"]) == (2, 2, 4, 2)
    seeds = sorted((r["problem"], r["seed"]) for r in row["results"])
    k0, k1 = sorted({k for k, _ in seeds})
    assert seeds == [(k0, 5 + k0), (k0, 1005 + k0), (k1, 5 + k1), (k1, 1005 + k1)]


def test_bench_planning_busy_runs_beside_busy_processes_and_ends_them(capsys):
    """--busy 2: two other processes keep a core busy each while the problems are planned,
    and none is left running after the table, when it ends normally or by an error."""
    import os
    from pathlib import Path

    def busy_children() -> list[str]:
        found = []
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
                cmdline = (stat.parent / "cmdline").read_bytes()
            except OSError:  # ended meanwhile
                continue
            if int(fields[1]) == os.getpid() and b"while True: pass" in cmdline:
                found.append(stat.parent.name)
        return found

    seen: list[list[str]] = []
    import robocell.apps.bench_planning as bench

    run_set = bench.run_set

    def spy(*args, **kwargs):  # type: ignore[no-untyped-def]
        seen.append(busy_children())
        return run_set(*args, **kwargs)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(bench, "run_set", spy)
        args = ["--robots", "panda", "--sets", "table_pick", "--limit", "1", "--busy", "2"]
        assert main(["bench", "planning", *args]) == 0
        assert "2 other process(es) keeping a core busy" in capsys.readouterr().out
        assert len(seen) == 1 and len(seen[0]) == 2
        assert busy_children() == []
        mp.setattr(bench, "run_set", lambda *a, **k: seen.append(busy_children()) or 1 / 0)
        with pytest.raises(ZeroDivisionError):
            bench.run(["panda"], ["table_pick"], limit=1, busy=1)
        assert len(seen[1]) == 1 and busy_children() == []


def test_speed_up_interval_holds_the_ratio_and_follows_each_problem():
    """The speed-up's interval (bootstrap over problems, all plans of a problem together): a
    baseline uniformly 10x slower gives 10 exactly; with times that vary from problem to
    problem, the interval holds the set's ratio of medians, is as wide as the spread allows,
    and repeats for the same seed; invalid problems are left out."""
    from robocell.apps.bench_planning import ProblemResult, ratio_interval

    def results(times, planner, runs=1):
        return [
            ProblemResult("panda", "s", k, planner, valid=t == t, time=t)
            for k, t in enumerate(times)
            for _ in range(runs)
        ]

    base = [0.001 * (1 + k % 7) for k in range(50)]
    lo, hi = ratio_interval(results(base, "robocell"), results([10 * t for t in base], "ompl"))
    assert lo == pytest.approx(10.0) and hi == pytest.approx(10.0)

    import numpy as np

    rng = np.random.default_rng(3)
    native = list(rng.uniform(0.5e-3, 2e-3, 50))
    other = list(rng.uniform(5e-3, 30e-3, 50))
    a, b = results(native, "robocell", runs=2), results(other, "ompl", runs=2)
    lo, hi = ratio_interval(a, b)
    ratio = np.median(other) / np.median(native)
    assert lo < ratio < hi and hi / lo > 1.2
    assert (lo, hi) == ratio_interval(a, b)
    invalid = results([*native[:-1], float("nan")], "robocell")
    assert np.isfinite(ratio_interval(invalid, results(other, "ompl"))).all()
    nothing = results([float("nan")] * 3, "robocell")
    assert np.isnan(ratio_interval(nothing, results(other[:3], "ompl"))).all()


def test_run_ratios_give_each_runs_own_ratio():
    """--runs N: each run's ratio of medians from that run's plans alone (a problem's r-th
    plans by both planners), so a baseline 8x slower in one run and 12x in the other gives
    8 and 12 while the pooled ratio lies between; invalid problems are left out."""
    import numpy as np

    from robocell.apps.bench_planning import ProblemResult, run_ratios

    rng = np.random.default_rng(5)
    native_times = rng.uniform(0.5e-3, 2e-3, (40, 2))
    factors = (8.0, 12.0)
    native, ompl = [], []
    for k in range(40):
        for r in range(2):
            t = native_times[k, r]
            native.append(ProblemResult("panda", "s", k, "robocell", True, time=t))
            ompl.append(ProblemResult("panda", "s", k, "ompl", True, time=factors[r] * t))
    assert run_ratios(native, ompl) == pytest.approx(list(factors))
    # a problem that is not valid counts in no run
    bad = [ProblemResult("panda", "s", 99, "robocell", False) for _ in range(2)]
    slow = [ProblemResult("panda", "s", 99, "ompl", False) for _ in range(2)]
    assert run_ratios(native + bad, ompl + slow) == pytest.approx(list(factors))
    assert run_ratios(bad, slow) == []
