"""``robocell run``: the seed's two user-code styles run as written (apart from the import
lines), in physics; the loop's pacing, stop and pause, and errors in user code."""

import sys
import threading
import time
from pathlib import Path

import pytest

from robocell.apps.cli import main
from robocell.errors import ExerciseError
from robocell.exercise import PickPlace
from robocell.exercise.runner import Session, detect_style, run_file

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "exercise"


@pytest.mark.parametrize("file", ["seed_myalgorithm.py", "seed_web.py"])
def test_the_seed_example_puts_the_blue_ball_in_its_tray(file, capsys):
    lines: list[str] = []
    result = run_file(EXAMPLES / file, max_time=5.0, printer=lines.append)
    assert result.status == "completed", result.error
    assert result.where["blue_ball"] == "in blue_tray"
    assert all(v == "not in a tray" for k, v in result.where.items() if k != "blue_ball")
    assert "HAL" not in sys.modules and "GUI" not in sys.modules
    if file == "seed_web.py":
        assert result.style == "web" and result.iterations >= 1
        assert "blue_ball rests at" in capsys.readouterr().out  # the user's print
    else:
        assert result.style == "script"


@pytest.fixture(scope="module")
def kin():
    return PickPlace("sorting", mode="kinematic", printer=lambda s: None)


def test_web_loop_runs_at_the_target_frequency_until_its_limit(kin):
    src = "from HAL import HAL\nn = 0\nwhile True:\n    n += 1\n    HAL.get_object_list()\n"
    s = Session(kin, frequency=50.0, max_iterations=6, printer=lambda s: None)
    r = s.run(src, "loop.py")
    assert (r.style, r.status, r.iterations) == ("web", "completed", 6)
    assert 0 < r.frequency <= 60


def test_web_loop_break_and_code_after_the_loop(kin, capsys):
    src = "i = 0\nwhile True:\n    i += 1\n    if i == 3:\n        break\nprint('after', i)\n"
    r = Session(kin, frequency=200.0, printer=lambda s: None).run(src, "b.py")
    assert r.status == "completed" and r.iterations == 3
    assert "after 3" in capsys.readouterr().out


def test_script_style_stop_and_pause_events(kin):
    src = (
        "import time\n"
        "def myalgorithm(self):\n"
        "    self.pick_place.back_to_home()\n"
        "    while True:\n"
        "        while (not self.pauseevent.isSet()) or (not self.stopevent.isSet()):\n"
        "            if not self.stopevent.isSet():\n"
        "                return\n"
        "        time.sleep(0.01)\n"
    )
    assert detect_style(__import__("ast").parse(src)) == "script"
    s = Session(kin, printer=lambda s: None)

    def buttons():
        time.sleep(0.2)
        s.pause()
        time.sleep(0.2)
        s.pause(False)
        time.sleep(0.1)
        s.stop()

    t = threading.Thread(target=buttons)
    t.start()
    r = s.run(src, "algo.py")
    t.join()
    assert (r.style, r.status) == ("script", "stopped")


def test_errors_in_user_code_are_reported_with_their_line(kin):
    src = "from HAL import HAL\nx = 1\nHAL.get_object_pose('purple_box')\n"
    r = Session(kin, printer=lambda s: None).run(src, "bad.py")
    assert r.status == "error" and r.exit_code == 1
    assert 'File "bad.py", line 3' in r.error and "purple_box" in r.error
    assert "HAL" not in sys.modules
    with pytest.raises(ExerciseError, match="bad2.py:2"):
        Session(kin, printer=lambda s: None).run("x = 1\ndef (:\n", "bad2.py")


def test_a_class_with_myalgorithm_runs(kin):
    src = (
        "class MyAlgorithm:\n"
        "    def myalgorithm(self):\n"
        "        self.found = self.pick_place.get_target_list()\n"
    )
    r = Session(kin, printer=lambda s: None).run(src, "cls.py")
    assert r.status == "completed", r.error


def test_cli_run_reports_a_missing_file(capsys):
    assert main(["run", "no/such/file.py"]) == 1
    assert "no such file" in capsys.readouterr().err
