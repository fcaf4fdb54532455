"""Long sessions stay healthy: memory, frame and polish times after thousands of edits, in the window and
through the engine API.

    python benchmarks/soak.py [MESH] [--cycles 1000] [--drags 10000] [--every 10] [--part window|engine|both]
    python benchmarks/soak.py --smoke          (a small generated shape, 30 cycles and 1,000 drags: seconds)

window
    The real window (its own Xvfb when there is no display) opens MESH (default data/creature.ply) at
    the default 5% cage, and each cycle, with real Qt mouse and key events: Select mode (S), an ROI
    rectangle (R) round one of :data:`REGIONS` cage points spread over the shape, a handle rectangle
    (H) round its middle, Drag mode (D), a drag of the handle by 24 pixels, release; then the settle
    and the polish on release (both on, the defaults) run to their end; Ctrl+Z (undoes the polish),
    Ctrl+Shift+Z (redoes it). Each cycle is a new selection. The regions come round every
    :data:`REGIONS` cycles, dragged one way on one round and back the other way on the next, so the
    shape stays near its first pose and every window of 2 x REGIONS cycles makes the same edits.
engine
    :class:`hybridedit.HybridEditor` on the same shape: ``--drags`` drags, a new selection (handle and
    region of interest round one of REGIONS shape vertices, from the current pose) every ``--every``,
    the handle moved out and back along a line, the direction turning round from one round to the next.

Recorded at 10%, 50% and 100% of the run (cycles 100, 500 and 1,000 by default): the resident set
(/proc/self/statm, after a garbage collection), and over the last 2 x REGIONS cycles (the last 5% of the
drags) the median engine frame time (one drag call; a window drag's interactive frames, not its settle),
the median polish time (the polish job's wall time, and per iteration), the undo history's steps and
memory (:class:`~hybridedit.viewer.model.history.History`) and the record's steps. Verdicts (PASS or
FAIL): memory, frame and polish medians at the end within 10% of the first checkpoint's; exit status 1
when one fails (not with --smoke: its windows are a few cycles, too few to judge).
"""

from __future__ import annotations

import argparse
import gc
import os
import resource
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))  # the tests' virtual X server

from support.xvfb import ensure_display  # noqa: E402

CREATURE = ROOT / "data" / "creature.ply"
REGIONS = 25
"""Regions the cycles go round (each window of 2 x REGIONS cycles makes the same edits)."""
TOLERANCE = 0.10
"""The verdicts: the end within this fraction of the first checkpoint."""
WINDOW_SIZE = (1100, 850)
DRAG_PIXELS = 24.0
ROI_SIDE, HANDLE_SIDE = 0.20, 0.06
"""The rectangles' sides, as fractions of the view's smaller side."""


def rss_mb() -> float:
    """The resident set size, MB (Linux; elsewhere the peak)."""
    try:
        with open("/proc/self/statm") as fh:
            pages = int(fh.read().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def machine() -> str:
    from common import machine as m

    return m()


@dataclass
class Checkpoint:
    """What a soak recorded at one point of its run."""

    at: int  # cycles (window) or drags (engine) done
    rss: float  # MB
    frame_ms: float  # median engine frame over the window before it
    polish_s: float = float("nan")  # median polish wall time
    polish_it_ms: float = float("nan")  # median polish time per iteration
    cycle_s: float = float("nan")  # median wall time of a cycle (window part)
    select_ms: float = float("nan")  # median set_selection (engine part)
    history: int = 0  # undo steps kept
    history_mb: float = 0.0  # their memory
    dropped: int = 0  # steps dropped since the start
    record: int = 0  # steps the record keeps (what Save Edit writes)
    seconds: float = 0.0  # since the start
    load: float = field(default_factory=lambda: os.getloadavg()[0])  # the machine's, over the last minute
    nones: int = field(default_factory=lambda: sys.getrefcount(None))  # (a binding that drops them crashes)


@dataclass
class Run:
    name: str
    unit: str
    checkpoints: list[Checkpoint] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    failed: list[str] = field(default_factory=list)  # hard failures (errors, non-finite poses)


def checkpoints_of(total: int) -> list[int]:
    return sorted({max(1, total // 10), max(1, total // 2), total})


def median(xs) -> float:
    xs = [x for x in xs if x == x]
    return float(np.median(xs)) if xs else float("nan")


# ---------------------------------------------------------------------------------------------- the window
class Window:
    """The editor window on one shape, and the user's mouse and keyboard on its 3D view (real Qt events)."""

    def __init__(self, path: Path, size=WINDOW_SIZE) -> None:
        from qtpy import QtCore, QtGui, QtTest, QtWidgets

        from hybridedit.viewer.window.main_window import MainWindow

        self.QtCore, self.QtGui, self.QtTest, self.QtWidgets = QtCore, QtGui, QtTest, QtWidgets
        self.app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
        self.w = w = MainWindow()
        w.resize(*size)
        w.show()
        w.activateWindow()
        self.pump(0.2)
        w.view.setFocus()
        t0 = time.perf_counter()
        if not w.loading.open_path(path):
            raise SystemExit(f"soak: {path}: the window did not open it")
        while w.jobs.worker is not None or w.session is None:
            self.pump(0.05)
            if time.perf_counter() - t0 > 1800:
                raise SystemExit(f"soak: {path}: the window did not load the mesh")
        self.open_seconds = time.perf_counter() - t0
        w.scene.reset_camera()
        w.view.request_render()
        self.pump(0.3)

    def close(self) -> None:
        self.w.unsaved.set_modified(False)  # (no Save / Discard question)
        self.w.close()
        self.app.processEvents()

    def pump(self, seconds: float = 0.0) -> None:
        end = time.perf_counter() + seconds
        while True:
            self.app.processEvents()
            if time.perf_counter() >= end:
                return
            time.sleep(0.004)

    def wait(self, done, what: str, timeout: float = 120.0) -> None:
        t0 = time.perf_counter()
        while not done():
            self.pump(0.005)
            if time.perf_counter() - t0 > timeout:
                raise RuntimeError(f"soak: {what} did not end in {timeout:.0f} s")

    # ------------------------------------------------------------------ where things are on screen
    def project(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(k, 2) display pixels (VTK's, y up) of world points (k, 3), and which are in front."""
        from hybridedit.viewer.model.picking import project_points

        d, front = project_points(np.asarray(pts, dtype=np.float64).reshape(-1, 3), self.w.scene.composite_matrix(),
                                  self.w.scene.display_size())
        return d[:, :2], front

    def widget(self, xy):
        return self.QtCore.QPointF(self.w.view.to_widget(float(xy[0]), float(xy[1])))

    # ------------------------------------------------------------------ the mouse and the keyboard
    def key(self, k, mods=None) -> None:
        Qt = self.QtCore.Qt
        self.QtTest.QTest.keyClick(self.w.view, k, Qt.KeyboardModifier.NoModifier if mods is None else mods)
        self.pump()

    def mouse(self, kind: str, xy, held: bool) -> None:
        Qt, E = self.QtCore.Qt, self.QtCore.QEvent.Type
        pos = self.widget(xy)
        view = self.w.view
        kinds = {"press": E.MouseButtonPress, "move": E.MouseMove, "release": E.MouseButtonRelease}
        button = Qt.MouseButton.NoButton if kind == "move" else Qt.MouseButton.LeftButton
        buttons = Qt.MouseButton.LeftButton if held else Qt.MouseButton.NoButton
        ev = self.QtGui.QMouseEvent(kinds[kind], pos, view.mapToGlobal(pos), button, buttons,
                                    Qt.KeyboardModifier.NoModifier)
        self.QtWidgets.QApplication.sendEvent(view, ev)

    def rectangle(self, a, b, steps: int = 4) -> None:
        """A left-button drag from display point a to b (a rubber band in Select mode)."""
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        self.mouse("press", a, True)
        for k in range(1, steps + 1):
            self.mouse("move", a + (b - a) * (k / steps), True)
            self.pump(0.003)
        self.mouse("release", b, False)
        self.pump(0.01)


def plan_regions(win: Window, n: int, rng: np.random.Generator) -> list[tuple[int, np.ndarray]]:
    """``n`` cage points in sight spread over the view (farthest point sampling on screen), each with a
    drag direction on screen (a unit vector): where the cycles select and drag."""
    s = win.w.session
    P = s.cage_positions
    d, front = win.project(P)
    width, height = win.w.scene.display_size()
    side = ROI_SIDE * min(width, height)
    inside = front & (d[:, 0] > side) & (d[:, 0] < width - side) & (d[:, 1] > side) & (d[:, 1] < height - side)
    # a handle rectangle must take a few points: those with the most neighbours on screen
    cand = np.flatnonzero(inside)
    near = np.array([np.count_nonzero(np.abs(d[inside] - d[i]).max(axis=1) < HANDLE_SIDE * min(width, height) / 2)
                     for i in cand])
    cand = cand[near >= 3]
    if cand.size < n:
        raise SystemExit(f"soak: only {cand.size} cage points in sight to select round; {n} needed")
    chosen = [int(cand[rng.integers(cand.size)])]
    dist = np.linalg.norm(d[cand] - d[chosen[0]], axis=1)
    while len(chosen) < n:
        j = int(cand[np.argmax(dist)])
        chosen.append(j)
        dist = np.minimum(dist, np.linalg.norm(d[cand] - d[j], axis=1))
    turns = rng.uniform(0.0, 2.0 * np.pi, n)
    return [(c, np.array([np.cos(t), np.sin(t)])) for c, t in zip(chosen, turns)]


def window_cycle(win: Window, point: int, direction: np.ndarray, stats: dict) -> None:
    """One cycle (see the module): a new selection, a drag, its settle and polish, undo and redo."""
    Qt = win.QtCore.Qt
    w = win.w
    s = w.session
    width, height = w.scene.display_size()
    unit = min(width, height)
    t0 = time.perf_counter()
    c = win.project(s.cage_positions[point][None])[0][0]
    win.key(Qt.Key.Key_S)  # Select mode
    win.key(Qt.Key.Key_R)  # target ROI
    half = 0.5 * ROI_SIDE * unit
    win.rectangle(c - half, c + half)
    win.key(Qt.Key.Key_H)  # target handle
    half = 0.5 * HANDLE_SIDE * unit
    win.rectangle(c - half, c + half)
    if not s.selection.handle.any():
        raise RuntimeError("soak: the handle rectangle took no cage point")
    win.key(Qt.Key.Key_D)  # Drag mode
    # press beside the gizmo (a drag in the view plane), on the far side from where the handle goes
    a = c - direction * 0.12 * unit
    fs = s.editor.frame_seconds
    n0 = len(fs)
    polished_before = w.posing.last_polish
    steps_before = len(s.history)
    win.mouse("press", a, True)
    if w.controller.gesture is None:
        raise RuntimeError("soak: the drag did not start")
    for k in range(1, 9):
        win.mouse("move", a + direction * DRAG_PIXELS * k / 8, True)
        win.pump(0.01)
    w.dragging.flush()  # (the last move's frame: then every interactive frame of the drag is timed)
    stats["frames"].extend(fs[n0:] if len(fs) >= n0 else fs[-8:])
    win.mouse("release", a + direction * DRAG_PIXELS, False)
    win.wait(lambda: not w.dragging.settle_timer.isActive() and not s.settling, "the settle")
    win.wait(lambda: not w.polisher.busy, "the polish", timeout=600.0)
    win.pump(0.01)  # (the polish's result, queued from its thread)
    out = w.posing.last_polish
    if out is not None and out is not polished_before:
        stats["polish"].append(out.seconds)
        stats["polish_it"].append(out.seconds / max(out.result.iterations, 1))
    if w.status.error_box is not None and w.status.error_box.isVisible():
        raise RuntimeError(f"soak: the window showed an error: {w.status.last_error}")
    if len(s.history) == steps_before and not s.history.dropped:
        raise RuntimeError("soak: the drag made no undo step")
    label = s.history.undo_label()
    win.key(Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)  # undo (the polish, or the drag)
    if s.history.redo_label() != label:
        raise RuntimeError("soak: Ctrl+Z undid nothing")
    win.key(Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)  # redo
    if s.history.can_redo():
        raise RuntimeError("soak: Ctrl+Shift+Z redid nothing")
    stats["cycle"].append(time.perf_counter() - t0)


def soak_window(path: Path, cycles: int, seed: int, window: int, history_mb: float | None = None) -> Run:
    """The window part (see the module); ``history_mb``: the undo history's budget (default: the window's)."""
    run = Run("window", "cycle")
    vd = ensure_display("1280x1024x24")
    if vd is not None and not vd.display:
        raise SystemExit(f"soak: no display and {vd.problem}")
    if sys.platform.startswith("linux"):
        os.environ.setdefault("QT_QPA_PLATFORM", "xcb")
    win = Window(path)
    s = win.w.session
    if history_mb is not None:
        s.history.budget = int(history_mb * 2**20)
    run.notes.append(f"{s.mesh.n_vertices:,} vertices, cage {s.n_cage:,}; opened in {win.open_seconds:.1f} s; "
                     f"undo history budget {s.history.budget / 2**20:.0f} MB, at most {s.history.limit} steps")
    regions = plan_regions(win, REGIONS, np.random.default_rng(seed))
    marks = checkpoints_of(cycles)
    per: list[dict] = []
    t_start = time.perf_counter()
    try:
        for k in range(cycles):
            point, direction = regions[k % REGIONS]
            sign = 1.0 if (k // REGIONS) % 2 == 0 else -1.0
            stats = {"frames": [], "polish": [], "polish_it": [], "cycle": []}
            window_cycle(win, point, sign * direction, stats)
            per.append(stats)
            if not np.isfinite(s.shape_positions).all():
                run.failed.append(f"non-finite pose after cycle {k + 1}")
                break
            if k + 1 in marks:
                gc.collect()
                last = per[-window:]
                h = s.history
                run.checkpoints.append(Checkpoint(
                    at=k + 1, rss=rss_mb(), frame_ms=1e3 * median([f for p in last for f in p["frames"]]),
                    polish_s=median([x for p in last for x in p["polish"]]),
                    polish_it_ms=1e3 * median([x for p in last for x in p["polish_it"]]),
                    cycle_s=median([x for p in last for x in p["cycle"]]), history=len(h),
                    history_mb=h.nbytes / 2**20, dropped=h.dropped, record=len(s.editor.record.packed),
                    seconds=time.perf_counter() - t_start))
                print_checkpoint(run, run.checkpoints[-1], flush=True)
    except RuntimeError as e:
        run.failed.append(f"{e} (cycle {len(per) + 1})")
    told = win.w.status.log.toPlainText().count("Undo history full")
    run.notes.append(f"the status bar's log says the history is full {told} time{'s' if told != 1 else ''}"
                     f" ({s.history.dropped:,} steps dropped)")
    win.close()
    return run


# ---------------------------------------------------------------------------------------------- the engine
def soak_engine(path: Path, drags: int, every: int, seed: int, window: int) -> Run:
    """The engine part (see the module)."""
    from hybridedit import HybridEditor, read_mesh, rigid_transform

    run = Run("engine", "drag")
    mesh = read_mesh(path)
    t0 = time.perf_counter()
    ed = HybridEditor(mesh, 0.05, cache=True)
    V = mesh.vertices
    diag = mesh.bbox_diagonal()
    rng = np.random.default_rng(seed)
    centres = rng.choice(mesh.n_vertices, REGIONS, replace=False)
    turns = rng.normal(size=(REGIONS, 3))
    turns /= np.linalg.norm(turns, axis=1, keepdims=True)
    run.notes.append(f"{mesh.n_vertices:,} vertices, cage {ed.cage.n_vertices:,}; built in "
                     f"{time.perf_counter() - t0:.1f} s; a new selection every {every} drags")
    marks = checkpoints_of(drags)
    frames: list[float] = []
    selects: list[float] = []
    t_start = time.perf_counter()
    sel = -1
    for i in range(drags):
        if i % every == 0:
            sel += 1
            q = sel % REGIONS
            P = ed.deformed_vertices
            d = np.linalg.norm(P - P[centres[q]], axis=1)
            t = time.perf_counter()
            ed.set_selection(np.flatnonzero(d < 0.04 * diag), roi=np.flatnonzero(d < 0.2 * diag))
            selects.append(time.perf_counter() - t)
            sign = 1.0 if (sel // REGIONS) % 2 == 0 else -1.0
        j = i % every + 1  # out and back along the line: the handle ends where the selection found it
        reach = 0.02 * diag * (1.0 - abs(2.0 * j / every - 1.0))
        t = time.perf_counter()
        out = ed.drag(transform=rigid_transform(translate=sign * reach * turns[q]))
        frames.append(time.perf_counter() - t)
        if not np.isfinite(out).all():
            run.failed.append(f"non-finite pose at drag {i + 1}")
            break
        if i + 1 in marks:
            gc.collect()
            n = max(window, 1)
            run.checkpoints.append(Checkpoint(
                at=i + 1, rss=rss_mb(), frame_ms=1e3 * median(frames[-n:]),
                select_ms=1e3 * median(selects[-max(n // every, 1):]), record=len(ed.record.packed),
                seconds=time.perf_counter() - t_start))
            print_checkpoint(run, run.checkpoints[-1], flush=True)
    run.notes.append(f"frame times the engine keeps: {len(ed.frame_seconds):,}")
    return run


# ---------------------------------------------------------------------------------------------- the report
def print_checkpoint(run: Run, c: Checkpoint, flush: bool = False) -> None:
    print(f"# soak {run.name}: {run.unit} {c.at:,} after {c.seconds:.0f} s: RSS {c.rss:.0f} MB, frame "
          f"{c.frame_ms:.2f} ms", flush=flush)


def print_run(run: Run) -> None:
    print(f"\nsoak {run.name}: " + "; ".join(run.notes))
    if run.name == "window":
        head = (f"{'cycle':>7} {'RSS MB':>8} {'frame ms':>9} {'polish s':>9} {'ms/iter':>8} {'cycle s':>8} "
                f"{'undo steps':>10} {'undo MB':>8} {'dropped':>8} {'record':>7} {'time s':>7} {'load':>5} "
                f"{'None refs':>10}")
        print(head)
        for c in run.checkpoints:
            print(f"{c.at:>7,} {c.rss:>8.0f} {c.frame_ms:>9.2f} {c.polish_s:>9.2f} {c.polish_it_ms:>8.1f} "
                  f"{c.cycle_s:>8.2f} {c.history:>10} {c.history_mb:>8.0f} {c.dropped:>8,} {c.record:>7,} "
                  f"{c.seconds:>7.0f} {c.load:>5.1f} {c.nones:>10,}")
    else:
        print(f"{'drag':>7} {'RSS MB':>8} {'frame ms':>9} {'select ms':>10} {'record':>7} {'time s':>7} {'load':>5}")
        for c in run.checkpoints:
            print(f"{c.at:>7,} {c.rss:>8.0f} {c.frame_ms:>9.2f} {c.select_ms:>10.1f} {c.record:>7,} {c.seconds:>7.0f} "
                  f"{c.load:>5.1f}")
    for f in run.failed:
        print(f"soak {run.name}: FAILED: {f}")


def verdicts(run: Run) -> list[tuple[str, bool]]:
    """(line, passed) for each measure: its value at the end against the first checkpoint's."""
    out = []
    if len(run.checkpoints) < 2:
        return [(f"soak {run.name}: verdicts: too few checkpoints ({len(run.checkpoints)}): FAIL", False)]
    first, last = run.checkpoints[0], run.checkpoints[-1]
    measures = [("memory", "rss", "MB", "{:.0f}"), ("frame time", "frame_ms", "ms", "{:.2f}")]
    if run.name == "window":
        measures.append(("polish time", "polish_s", "s", "{:.2f}"))
    for name, attr, unit, fmt in measures:
        a, b = getattr(first, attr), getattr(last, attr)
        change = (b - a) / a if a else float("nan")
        ok = change == change and change <= TOLERANCE
        out.append((f"soak {run.name}: {name} at {run.unit} {last.at:,} {fmt.format(b)} {unit} vs "
                    f"{fmt.format(a)} at {run.unit} {first.at:,}: {change:+.1%} "
                    f"(at most +{TOLERANCE:.0%}): {'PASS' if ok else 'FAIL'}", ok))
    return out


def smoke_mesh() -> Path:
    """A small closed shape (2,562 vertices, a stretched bumpy sphere) written to a temporary file."""
    import trimesh

    from hybridedit.core.mesh import Mesh
    from hybridedit.fileio.meshfiles import write_mesh

    t = trimesh.creation.icosphere(subdivisions=4)
    v = np.asarray(t.vertices) * np.array([2.0, 1.0, 1.0])
    v *= (1.0 + 0.05 * np.sin(5 * v[:, 0]) * np.cos(4 * v[:, 1]))[:, None]
    p = Path(tempfile.mkdtemp(prefix="soak-")) / "smoke.ply"
    write_mesh(p, Mesh(v, np.asarray(t.faces), name="smoke"))
    return p


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh", nargs="?", type=Path, help=f"mesh file (default {CREATURE.relative_to(ROOT)})")
    ap.add_argument("--cycles", type=int, default=1000, help="window cycles (default 1,000)")
    ap.add_argument("--drags", type=int, default=10000, help="engine drags (default 10,000)")
    ap.add_argument("--every", type=int, default=10, help="engine drags per selection (default 10)")
    ap.add_argument("--part", choices=("window", "engine", "both"), default="both")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--history-mb", type=float, help="the window's undo history budget, MB (default: the window's, "
                                                     "sized to the shape; --smoke: 4, so that it fills)")
    ap.add_argument("--smoke", action="store_true", help="a small generated shape, 30 cycles and 1,000 drags")
    args = ap.parse_args(argv)
    global REGIONS
    if args.smoke:
        args.mesh = args.mesh or smoke_mesh()
        args.cycles, args.drags = min(args.cycles, 30), min(args.drags, 1000)
        REGIONS = 5
        args.history_mb = 4.0 if args.history_mb is None else args.history_mb
    path = args.mesh or CREATURE
    if not path.is_file():
        print(f"soak: {path}: no such file", file=sys.stderr)
        return 2
    print(f"soak: {path.name}; {machine()}", flush=True)
    runs = []
    if args.part in ("window", "both"):
        runs.append(soak_window(path, args.cycles, args.seed, 2 * REGIONS, args.history_mb))
    if args.part in ("engine", "both"):
        runs.append(soak_engine(path, args.drags, args.every, args.seed, max(args.drags // 20, 1)))
    ok = True
    for run in runs:
        print_run(run)
        ok = ok and not run.failed
    print()
    for run in runs:
        for line, passed in verdicts(run):
            print(line)
            ok = ok and (passed or args.smoke)
    return 0 if ok else 1


if __name__ == "__main__":
    from hybridedit.viewer.shutdown import leave

    leave(main())  # no interpreter teardown of Qt and VTK (it can abort after the work is done)
