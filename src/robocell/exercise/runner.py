"""Run a user's exercise file in either of the seed's two styles (``robocell run FILE``).

- Web template: ``from HAL import HAL`` (and ``from GUI import GUI``), sequential code, then a
  ``while True:`` loop whose body runs at a target frequency until stopped. The loop is rewritten
  to iterate on a paced clock (``break`` and ``continue`` keep working); the measured frequency
  is reported at the end.
- Script template: a ``myalgorithm(self)`` function (or a method of a class) that calls
  ``self.pick_place.<api>`` and checks ``self.pauseevent`` / ``self.stopevent`` between actions.
  As in the seed, the events are *set* while the algorithm may run: the stop button (here:
  Ctrl-C, or :meth:`Session.stop`) clears ``stopevent``, pause clears ``pauseevent``.

The user's code runs in the main thread; the physics steps in its own thread.
"""

from __future__ import annotations

import ast
import signal
import sys
import tempfile
import threading
import time
import traceback
import types
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robocell.errors import ExerciseError
from robocell.exercise.pick_place import PickPlace

STYLES = ("web", "script")


class Event(threading.Event):
    """threading.Event with the seed's spelling ``isSet`` (deprecated in the standard one)."""

    def isSet(self) -> bool:  # noqa: N802 (the seed's name)
        return self.is_set()


@dataclass
class Algorithm:
    """What ``self`` is in the script template's ``myalgorithm(self)`` (it may keep its own
    attributes too)."""

    pick_place: PickPlace
    pauseevent: Event
    stopevent: Event


class Gui:
    """The web template's ``GUI``: ``showImage(image)`` saves each image shown as a PNG in
    ``folder`` (a temporary folder unless given) and remembers the last one."""

    def __init__(self, folder: Path | None = None, printer: Callable[[str], None] = print) -> None:
        self.folder = folder
        self.printer = printer
        self.last_image: np.ndarray | None = None
        self.count = 0

    def showImage(self, image: Any) -> Path:  # noqa: N802 (the seed's name)
        import matplotlib.image

        img = np.asarray(image)
        if img.ndim not in (2, 3) or img.size == 0:
            raise ExerciseError(
                f"GUI.showImage needs an image array (H×W or H×W×3), got {img.shape}"
            )
        if self.folder is None:
            self.folder = Path(tempfile.mkdtemp(prefix="robocell-gui-"))
            self.printer(f"GUI: images are saved in {self.folder}")
        self.folder.mkdir(parents=True, exist_ok=True)
        path = self.folder / f"image_{self.count:05d}.png"
        matplotlib.image.imsave(path, img if img.ndim == 3 else img, cmap="gray")
        self.last_image, self.count = img, self.count + 1
        return path


@dataclass
class RunResult:
    """How a run ended: ``status`` "completed", "stopped" or "error"; the loop's iterations and
    measured frequency (web style); the error text, if any."""

    style: str
    status: str
    iterations: int = 0
    frequency: float = 0.0
    error: str = ""
    where: dict[str, str] = field(default_factory=dict)

    @property
    def exit_code(self) -> int:
        return {"completed": 0, "stopped": 130}.get(self.status, 1)


def detect_style(tree: ast.Module) -> str:
    """ "script" when the file defines ``myalgorithm`` (at the top or in a class), else "web"."""
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.name == "myalgorithm":
            return "script"
        if isinstance(node, ast.ClassDef) and any(
            isinstance(n, ast.FunctionDef) and n.name == "myalgorithm" for n in node.body
        ):
            return "script"
    return "web"


class _PacedLoop(ast.NodeTransformer):
    """Top-level ``while True:`` → ``for _ in __robocell_ticks__():`` (the first one only)."""

    def __init__(self) -> None:
        self.found = False

    def visit_Module(self, node: ast.Module) -> ast.Module:  # noqa: N802 (ast's name)
        body: list[ast.stmt] = []
        for stmt in node.body:
            if (
                not self.found
                and isinstance(stmt, ast.While)
                and isinstance(stmt.test, ast.Constant)
                and stmt.test.value is True
                and not stmt.orelse
            ):
                self.found = True
                loop = ast.For(
                    target=ast.Name("__robocell_tick__", ast.Store()),
                    iter=ast.Call(ast.Name("__robocell_ticks__", ast.Load()), [], []),
                    body=stmt.body,
                    orelse=[],
                )
                body.append(ast.copy_location(loop, stmt))
            else:
                body.append(stmt)
        node.body = body
        return node


class Session:
    """One run of a user's file on a :class:`PickPlace`. ``frequency`` [Hz]: the web loop's
    target; ``max_time`` [s] and ``max_iterations`` end the loop (default: run until stopped)."""

    def __init__(
        self,
        pick_place: PickPlace,
        frequency: float = 10.0,
        max_time: float | None = None,
        max_iterations: int | None = None,
        gui_folder: Path | None = None,
        printer: Callable[[str], None] = print,
    ) -> None:
        if not frequency > 0:
            raise ExerciseError(f"the loop's target frequency must be > 0 Hz, got {frequency!r}")
        self.pick_place = pick_place
        self.frequency = float(frequency)
        self.max_time = max_time
        self.max_iterations = max_iterations
        self.printer = printer
        self.gui = Gui(gui_folder, printer)
        self.stopevent = Event()
        self.pauseevent = Event()
        self.iterations = 0
        self._loop_s = 0.0

    def stop(self) -> None:
        """The stop button: clear ``stopevent`` and stop the robot."""
        self.stopevent.clear()
        self.pick_place.stop()

    def pause(self, paused: bool = True) -> None:
        """The pause button: clear (or set again) ``pauseevent``."""
        if paused:
            self.pauseevent.clear()
        else:
            self.pauseevent.set()

    def _ticks(self) -> Iterator[int]:
        period = 1.0 / self.frequency
        start = time.perf_counter()
        next_t = start
        while self.stopevent.is_set():
            if self.max_iterations is not None and self.iterations >= self.max_iterations:
                break
            now = time.perf_counter()
            if self.max_time is not None and now - start >= self.max_time:
                break
            while not self.pauseevent.is_set() and self.stopevent.is_set():
                time.sleep(0.01)
            self.iterations += 1
            yield self.iterations
            self._loop_s = time.perf_counter() - start
            next_t += period
            delay = next_t - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            else:
                next_t = time.perf_counter()  # behind: do not try to catch up

    def run(self, source: str, filename: str = "<exercise>") -> RunResult:
        try:
            tree = ast.parse(source, filename)
        except SyntaxError as exc:
            raise ExerciseError(f"{filename}:{exc.lineno}: {exc.msg}") from exc
        style = detect_style(tree)
        if style == "web":
            loop = _PacedLoop()
            tree = ast.fix_missing_locations(loop.visit(tree))
        code = compile(tree, filename, "exec")
        namespace: dict[str, Any] = {
            "__name__": "__main__" if style == "web" else "robocell_exercise",
            "__file__": filename,
            "__robocell_ticks__": self._ticks,
        }
        hal = types.ModuleType("HAL", "the exercise API (robocell)")
        hal.HAL = self.pick_place  # type: ignore[attr-defined]
        gui = types.ModuleType("GUI", "the exercise GUI (robocell)")
        gui.GUI = self.gui  # type: ignore[attr-defined]
        saved = {k: sys.modules.get(k) for k in ("HAL", "GUI")}
        sys.modules.update(HAL=hal, GUI=gui)
        self.stopevent.set()
        self.pauseevent.set()
        status, error = "completed", ""
        try:
            exec(code, namespace)
            if style == "script":
                self._call_myalgorithm(namespace, filename)
            if not self.stopevent.is_set():
                status = "stopped"
        except KeyboardInterrupt:
            self.stop()
            status = "stopped"
        except Exception as exc:  # the user's code failed: report it as the console would
            self.pick_place.stop()
            status = "error"
            error = _user_traceback(exc, filename)
        finally:
            for k, v in saved.items():
                if v is None:
                    sys.modules.pop(k, None)
                else:
                    sys.modules[k] = v
        freq = self.iterations / self._loop_s if self._loop_s > 0 else 0.0
        return RunResult(style, status, self.iterations, freq, error)

    def _call_myalgorithm(self, namespace: dict[str, Any], filename: str) -> None:
        fn = namespace.get("myalgorithm")
        if not callable(fn):
            fn = next(
                (
                    getattr(v, "myalgorithm")  # noqa: B009 (a user's class: unknown to mypy)
                    for v in namespace.values()
                    if isinstance(v, type) and callable(getattr(v, "myalgorithm", None))
                ),
                None,
            )
        if fn is None:
            raise ExerciseError(f"{filename}: no myalgorithm(self) to run")
        fn(Algorithm(self.pick_place, self.pauseevent, self.stopevent))


def _user_traceback(exc: BaseException, filename: str) -> str:
    """The exception, with only the frames of the user's file (robocell's own are noise)."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename == filename]
    lines = traceback.format_list(frames) if frames else []
    return "".join(lines) + "".join(traceback.format_exception_only(type(exc), exc))


def run_file(
    path: str | Path,
    cell: str = "sorting",
    layout: int = 0,
    mode: str = "physics",
    frequency: float = 10.0,
    max_time: float | None = None,
    max_iterations: int | None = None,
    gui_folder: Path | None = None,
    printer: Callable[[str], None] = print,
) -> RunResult:
    """Load ``cell`` and run the user's file on it; print where every object ended up."""
    p = Path(path)
    if not p.is_file():
        raise ExerciseError(f"no such file: {p}")
    try:
        source = p.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ExerciseError(f"cannot read {p}: {exc}") from exc
    pick_place = PickPlace(cell, layout, mode, printer=printer)
    session = Session(pick_place, frequency, max_time, max_iterations, gui_folder, printer)
    style = detect_style(ast.parse(source)) if _parses(source) else "web"
    printer(f"robocell run: {p.name} ({style} style) on the {cell} cell, {mode} mode")
    previous = None
    if threading.current_thread() is threading.main_thread() and style == "script":

        def on_sigint(signum: int, frame: Any) -> None:
            if session.stopevent.is_set():
                printer("stop: the algorithm ends at its next check (Ctrl-C again to quit)")
                session.stop()
            else:
                raise KeyboardInterrupt

        previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        result = session.run(source, str(p))
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    if result.error:
        printer(result.error.rstrip())
    if result.style == "web" and result.iterations:
        printer(
            f"loop: {result.iterations} iterations, measured {result.frequency:.1f} Hz "
            f"(target {frequency:g} Hz)"
        )
    result.where = where_objects(pick_place)
    for name, place in result.where.items():
        printer(f"  {name:15} {place}")
    printer(f"{result.status}")
    return result


def _parses(source: str) -> bool:
    try:
        ast.parse(source)
    except SyntaxError:
        return False
    return True


def where_objects(pick_place: PickPlace) -> dict[str, str]:
    """Each object's whereabouts: the fixture it is inside (a tray), or held, or what it
    rests on."""
    cell = pick_place.cell
    out = {}
    for name in cell.object_names:
        if name in cell.scene.attached_objects:
            out[name] = "held"
            continue
        inside = cell.container_of(name)
        out[name] = f"in {inside}" if inside else "not in a tray"
    return out
