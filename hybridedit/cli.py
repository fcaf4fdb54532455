"""The `hybridedit` command: batch deformation, mesh info, and the editor window."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .fileio.atomic import WriteError, atomic_write
from .fileio.editfile import EditFileError, load_edit
from .deform.selection import SelectionError
from .fileio.meshfiles import SUPPORTED_EXTENSIONS, MeshFileError, read_document, read_mesh, write_document, write_mesh
from .core.mesh import MeshError, edge_error_stats, rrms_edge_error
from .fileio.outpaths import OutputPathError, check_outputs
from .defaults import CAGE_SIZE, ITERATIONS, POLISH_MAX_ITERATIONS, SETTLE_FRAMES, TRUNCATION
from .core.command_line import CLIError, one_line, parse_cage_size
from .core.progress import SHOW_AFTER_SECONDS, TextProgress

if TYPE_CHECKING:
    from .deform.editor import HybridEditor

def _default_mesh(here: Path | None = None) -> Path:
    """The default mesh: inside the package when installed from a wheel (hybridedit/data/, see
    pyproject.toml), else the checkout's data/creature.ply (an editable install, a checkout).
    ``here``: the package folder (this module's)."""
    here = Path(__file__).resolve().parent if here is None else Path(here)
    packaged = here / "data" / "creature.ply"
    return packaged if packaged.is_file() else here.parent / "data" / "creature.ply"


DEFAULT_MESH = _default_mesh()


_PROGRESS: list[TextProgress] = []
"""The progress printers of the command running (their open lines end before an error is printed)."""


def _progress(quiet: bool, stream=None):
    """A progress callback for HybridEditor and the CLI's own steps, on stderr
    (:class:`hybridedit.core.progress.TextProgress`: the time left on a terminal)."""
    say = TextProgress(quiet, stream)
    _PROGRESS.append(say)
    return say


def _end_progress_lines() -> None:
    """A step stopped by an error leaves its line open on the terminal: end it, so that the error
    is printed on a line of its own."""
    for say in _PROGRESS:
        say.end_line()


class _SlowSteps:
    """Pass a step's progress on only once it has run :data:`SHOW_AFTER_SECONDS`: reading and
    writing a file end with a summary line of their own, and most files take a fraction of a
    second (a refused file says only its error)."""

    def __init__(self, say, clock=time.perf_counter) -> None:
        self.say, self._clock = say, clock
        self._started: dict[str, float] = {}
        self._shown: set[str] = set()

    def __call__(self, step: str, fraction: float) -> None:
        now = self._clock()
        t0 = self._started.setdefault(step, now)
        if step in self._shown or now - t0 >= SHOW_AFTER_SECONDS:
            self._shown.add(step)
            self.say(step, fraction)


def run_deform(args: argparse.Namespace) -> int:
    """``hybridedit deform``: replay an edit file on a mesh, polish if asked, write the result (and
    ``--stats``), saying each step on stderr."""
    say = _progress(args.quiet)
    src, dst = Path(args.input), Path(args.output)
    _check_deform_arguments(args, src, dst)
    t_start = time.perf_counter()
    from .deform.editor import HybridEditor  # the compiled engine loads after the cheap checks
    from .binding.rig import build_rig

    edit = load_edit(args.edit)
    cage = _cage_size(args, edit)
    doc = _read_input(src, say)
    mesh = doc.mesh
    options = dict(weights=args.weights, iterations=args.iterations, propagation=args.propagation)

    def editor_on(size: int | float) -> "HybridEditor":
        rig = build_rig(mesh, cage_size=size, truncation=args.truncation, cache=not args.no_cache, progress=say)
        return HybridEditor(rig, **options)

    ed = editor_on(cage)
    _say_rig(ed, src, say)
    for note in _replay_notes(edit, ed, explicit_cage=args.cage is not None):
        print(f"hybridedit: note: {Path(args.edit).name}: {note}", file=sys.stderr, flush=True)
    V = _replay(ed, edit, args, editor_on, say)
    before_polish = V.copy() if args.polish is not None else None
    polished = _polish_if_asked(ed, edit, args, say)
    if polished is not None:
        V = ed.deformed_vertices
    _write_output(dst, doc, V, say)
    _give_stats(args, _deform_stats(args, src, dst, mesh, ed, edit, V, t_start, polished, before_polish))
    return 0


def _check_deform_arguments(args: argparse.Namespace, src: Path, dst: Path) -> None:
    """The checks that need no file read: the output paths, and the numbers (CLIError)."""
    check_outputs({"-o": (dst, SUPPORTED_EXTENSIONS), "--stats": (args.stats, (".json",))},
                  inputs={"input": src, "edit": args.edit},
                  may_overwrite=("-o",) if args.force else ())
    if args.iterations < 0:
        raise CLIError(f"--iterations must be >= 0, got {args.iterations}")
    if args.frames < 1:
        raise CLIError(f"--frames must be >= 1, got {args.frames}")
    if args.polish is not None and args.polish < 1:
        raise CLIError(f"--polish must be a number of iterations >= 1, got {args.polish}")


def _cage_size(args: argparse.Namespace, edit) -> int | float:
    """The cage to build: --cage, else the size the edit's last step with a cage records, else the default."""
    recorded = [s.cage for s in edit.steps if s.cage is not None]
    return args.cage if args.cage is not None else (recorded[-1]["size"] if recorded else CAGE_SIZE)


def _read_input(src: Path, say):
    """The input mesh file as a Document, with its summary line."""
    t_read = time.perf_counter()
    doc = read_document(src, progress=_SlowSteps(say))
    mesh = doc.mesh
    say(f"read {src.name}: {mesh.n_vertices} vertices, {mesh.n_faces} faces ({time.perf_counter() - t_read:.2f} s)")
    return doc


def _say_rig(ed: "HybridEditor", src: Path, say) -> None:
    """The cage and binding built (or read from the cache), and the notes of their building."""
    say(
        f"cage {ed.cage.n_vertices} vertices ({ed.timings['cage_seconds']:.2f} s"
        f"{', from the cache' if ed.cache_hit else ''}), "
        f"bound with {ed.nnz_per_row:.1f} coordinates a vertex ({ed.timings['bind_seconds']:.2f} s)"
    )
    for note in ed.notes:
        print(f"hybridedit: note: {src.name}: {note}", file=sys.stderr, flush=True)


def _replay(ed: "HybridEditor", edit, args: argparse.Namespace, editor_on, say) -> np.ndarray:
    """The edit replayed from the rest pose (each step on the cage it records, unless --cage says
    one cage); the deformed shape, checked finite."""
    other_cages = None if args.cage is not None else (lambda c: editor_on(c["size"]))
    steps = len(edit.steps)
    say(f"deforming: {steps} step{'s' if steps > 1 else ''}" if steps > 1 or edit.iterations is not None
        else f"deforming: {args.frames} frames of {args.iterations} ARAP iterations")
    try:
        ed.reset()
        V = ed.apply_edit(edit, frames=args.frames, path=str(args.edit), progress=say, editor_for_cage=other_cages)
    except EditFileError:
        raise
    except ValueError as e:  # SelectionError, or a transform the editor refuses
        raise CLIError(f"{args.edit}: {one_line(e)}") from None
    if not np.all(np.isfinite(V)):
        raise CLIError("the deformation produced non-finite positions; the edit is too extreme")
    return V


def _polish_if_asked(ed: "HybridEditor", edit, args: argparse.Namespace, say):
    """--polish, unless the edit's last step records its own polish (a note says so): its
    PolishResult, or None."""
    if args.polish is None:
        return None
    if edit.polish is not None:
        print(f"hybridedit: note: {Path(args.edit).name}: its last step records its polish "
              f"({edit.polish} iterations), replayed as recorded; --polish adds none", file=sys.stderr)
        return None
    return _polish(ed, args.polish, say)


def _write_output(dst: Path, doc, V: np.ndarray, say) -> None:
    """The input document with the deformed positions, written to ``dst``, with its notes."""
    t_write = time.perf_counter()
    for note in write_document(dst, doc.with_vertices(V), progress=_SlowSteps(say)):
        print(f"hybridedit: note: {dst.name}: {note}", file=sys.stderr, flush=True)
    say(f"wrote {dst} ({time.perf_counter() - t_write:.2f} s)")


def _deform_stats(args: argparse.Namespace, src: Path, dst: Path, mesh, ed: "HybridEditor", edit, V: np.ndarray,
                  t_start: float, polished=None, before_polish: np.ndarray | None = None) -> dict:
    """The figures of a deform run (what --stats writes): sizes, times, settings, edge errors, and
    the polish's (``polished``, its PolishResult, from the pose ``before_polish``)."""
    frame_ms = np.asarray(ed.frame_seconds) * 1e3
    edges = mesh.edges()
    rrms, max_stretch = edge_error_stats(mesh.vertices, V, edges)
    stats = {
        "input": str(src),
        "output": str(dst),
        "n_vertices": mesh.n_vertices,
        "n_faces": mesh.n_faces,
        "cage_vertices": ed.cage.n_vertices,
        "cage_faces": ed.cage.n_faces,
        "cage_seconds": ed.timings["cage_seconds"],
        "bind_seconds": ed.timings["bind_seconds"],
        "cache_hit": ed.cache_hit,
        "nnz_per_row": ed.nnz_per_row,
        "nnz_per_row_max": int(np.diff(ed.M.indptr).max()),
        "truncation": ed.truncation,
        "weights": args.weights,
        "iterations": args.iterations,
        "frames": args.frames,
        "steps": len(edit.steps),
        "frame_ms_median": float(np.median(frame_ms)),
        "frame_ms_max": float(frame_ms.max()),
        "handle_groups": ed.n_groups,
        "handle_cage_vertices": int(ed.handle.size),
        "fixed_cage_vertices": int(ed.fixed.size),
        "propagation": args.propagation,
        "rrms_edge_error_percent": rrms,
        "max_stretch_percent": max_stretch,
        "total_seconds": time.perf_counter() - t_start,
    }
    if polished is not None:
        stats.update(
            polish_seconds=polished.seconds,
            polish_iterations=polished.iterations,
            polish_stopped=polished.stopped,
            rrms_edge_error_before_polish_percent=rrms_edge_error(mesh.vertices, before_polish, edges),
        )
    return stats


def _give_stats(args: argparse.Namespace, stats: dict) -> None:
    """--stats's JSON file, and (unless --quiet) the main figures on stderr."""
    if args.stats:
        with atomic_write(Path(args.stats), "w") as fh:
            json.dump(stats, fh, indent=1)
            fh.write("\n")
    if not args.quiet:
        for k in ("cage_vertices", "cage_seconds", "bind_seconds", "nnz_per_row", "frame_ms_median",
                  "rrms_edge_error_percent", "max_stretch_percent", "rrms_edge_error_before_polish_percent"):
            if k not in stats:
                continue
            v = stats[k]
            print(f"  {k:24s} {v:.4g}" if isinstance(v, float) else f"  {k:24s} {v}", file=sys.stderr)


def _replay_notes(edit, ed: "HybridEditor", *, explicit_cage: bool) -> list[str]:
    """What a user should know before a replay that will not give the pose the edit was saved from."""
    notes = []
    mine = {"size": ed.rig.cage_size, "vertices": ed.cage.n_vertices}
    cages = {(c["size"], c["vertices"]) for c in (s.cage for s in edit.steps) if c is not None}
    if explicit_cage and cages - {(mine["size"], mine["vertices"])}:
        counts = sorted({v for _, v in cages})
        made = (f"a cage of {counts[0]:,} vertices" if len(counts) == 1 else
                "cages of " + ", ".join(f"{v:,}" for v in counts[:-1]) + f" and {counts[-1]:,} vertices")
        notes.append(f"made on {made}; replayed on --cage's {mine['vertices']:,} as asked, so the pose differs "
                     "from the one it was saved from (leave --cage out for the cages it was made on)")
    last = edit.steps[-1].cage
    if not explicit_cage and last is not None and last["vertices"] != mine["vertices"]:
        notes.append(f"its last step ran on a cage of {last['vertices']:,} vertices; the cage built here at that "
                     f"size has {mine['vertices']:,}, so the pose may differ slightly")
    return notes


def _polish(ed: "HybridEditor", max_iterations: int, say):
    """Full-resolution ARAP of the edited region until converged, at most ``max_iterations``."""
    say("polishing", 0.0)
    free = int(ed.free_mask.sum())
    r = ed.polish(max_iterations=max_iterations)
    say("polishing", 1.0)
    say(f"polished {free} vertices: {r.iterations} iterations ({r.stopped}), "
        f"ARAP energy {r.energy_before:.4g} -> {r.energy_after:.4g}")
    return r


def run_info(args: argparse.Namespace) -> int:
    from .core.meshinfo import format_report, mesh_report

    from .core.repair import cage_source

    mesh = read_mesh(args.input)
    rep = mesh_report(mesh)
    try:
        _, repairs = cage_source(mesh)
    except MeshError as e:
        repairs = [f"no cage can be built: {e}"]
    if args.json:
        rep["cage_repairs"] = repairs
        print(json.dumps(rep, indent=1))
    else:
        print(format_report(rep))
        if repairs:
            print("  the cage is built from a repaired copy (the mesh itself is kept as is):")
            for note in repairs:
                print(f"    - {note}")
    return 0


def run_open(args: argparse.Namespace) -> int:
    path = Path(args.mesh) if args.mesh else DEFAULT_MESH
    try:
        from .viewer.app import main as viewer_main  # noqa: F401  (the window, when installed)
    except ImportError:
        viewer_main = None
    if viewer_main is not None:
        return int(viewer_main(path, screenshot=args.screenshot, cage=args.cage) or 0)
    return _demo(path, args)


def run_web(args: argparse.Namespace) -> int:
    """``hybridedit web``: the editor in a browser (:mod:`hybridedit.web`)."""
    path = Path(args.mesh) if args.mesh else DEFAULT_MESH
    if not path.is_file():
        raise CLIError(f"{path}: no such file")
    if not 0 < args.port < 65536:
        raise CLIError(f"--port {args.port}: not a port number (1 to 65535)")
    edit = load_edit(args.edit) if args.edit else None  # (a bad edit file is said before the build)
    import importlib.util
    import socket

    missing = [m for m in ("trame", "trame_vtk", "trame_vuetify") if importlib.util.find_spec(m) is None]
    if missing:
        raise CLIError(f"the web editor needs {', '.join(missing)}: pip install 'hybridedit[web]'")
    try:  # said before the shape is bound (which takes a while), not after
        with socket.socket() as probe:
            probe.bind((args.host, args.port))
    except OSError as e:
        raise CLIError(f"cannot listen on {args.host}:{args.port} ({e.strerror or e}); try another --port") from e
    from .web.editor_app import run

    return run(path, host=args.host, port=args.port, cage_size=args.cage, edit=edit,
               edit_path=args.edit)


def _demo(path: Path, args: argparse.Namespace) -> int:
    """Batch demo edit: raise the part of the shape furthest along +X."""
    say = _progress(False)
    out = Path(args.output or "hybridedit-demo.ply")
    check_outputs({"-o": (out, SUPPORTED_EXTENSIONS)}, inputs={"input": path})
    from .deform.editor import HybridEditor

    mesh = read_mesh(path)
    say(f"demo on {path.name}: {mesh.n_vertices} vertices")
    ed = HybridEditor(mesh, args.cage, progress=say)
    x = mesh.vertices[:, 0]
    lo, hi = x.min(), x.max()
    handle = np.flatnonzero(x > hi - 0.15 * (hi - lo))
    roi = np.flatnonzero(x > lo + 0.55 * (hi - lo))
    ed.set_selection(handle, roi=roi)
    lift = 0.15 * mesh.bbox_diagonal()
    for _ in range(30):
        V = ed.drag(translate=(0.0, lift, 0.0))
    write_mesh(out, ed.deformed)
    say(
        f"raised the +X end by {lift:.3g}; median frame {np.median(ed.frame_seconds) * 1e3:.2f} ms; "
        f"edge RRMS error {rrms_edge_error(mesh.vertices, V, mesh.edges()):.2f}%; wrote {out}"
    )
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="hybridedit", description="Hybrid (cage + ARAP) mesh editing.")
    sub = p.add_subparsers(dest="command")
    d = sub.add_parser("deform", help="apply an edit file to a mesh and save the result")
    d.add_argument("input", help="input mesh (.obj .ply .stl .off .glb)")
    d.add_argument("-o", "--output", required=True, help="output mesh (.obj .ply .stl .off .glb)")
    d.add_argument("--edit", required=True, help="edit file (JSON)")
    d.add_argument("--cage", type=parse_cage_size, default=None,
                   help="cage vertices (2000) or fraction (0.05 or 5%%); default: the cage the edit was made on "
                        "(its file says), else 5%%")
    d.add_argument("--iterations", type=int, default=ITERATIONS, help=f"ARAP iterations per frame (default {ITERATIONS})")
    d.add_argument("--frames", type=int, default=SETTLE_FRAMES,
                   help="frames to run for a step whose file does not record its iterations (default 30; an edit "
                        "saved in the window records them)")
    d.add_argument("--weights", choices=("uniform", "cotangent"), default="cotangent",
                   help="ARAP weights on the cage (default cotangent: lower edge error than the paper's uniform in benchmarks/table1.py)")
    d.add_argument("--polish", type=int, nargs="?", const=POLISH_MAX_ITERATIONS, default=None,
                   metavar="ITERATIONS",
                   help="after the replay, run full-resolution ARAP on the edited region until it converges, at "
                        f"most ITERATIONS (default {POLISH_MAX_ITERATIONS}); a step saved with its polish replays "
                        "it anyway")
    d.add_argument("--propagation", choices=("residual", "linear"), default="residual",
                   help="residual: exact rest pose, detail rotated with the cage (default); linear: the paper's x' = M y'")
    d.add_argument("--truncation", type=float, default=TRUNCATION,
                   help=f"coordinate magnitude dropped per vertex (default {TRUNCATION:g})")
    d.add_argument("--stats", help="write timing and quality figures to this JSON file")
    d.add_argument("--force", action="store_true", help="allow overwriting the input mesh")
    d.add_argument("--no-cache", action="store_true", help="do not read or write the cage/binding cache")
    d.add_argument("-q", "--quiet", action="store_true", help="no progress messages")
    d.set_defaults(func=run_deform)
    from .batching.command import add_parser as add_batch_parser

    add_batch_parser(sub)
    i = sub.add_parser("info", help="print a mesh's size and topology")
    i.add_argument("input")
    i.add_argument("--json", action="store_true", help="print JSON")
    i.set_defaults(func=run_info)
    w = sub.add_parser("web", help="serve the editor to a browser (needs the web extra: pip install hybridedit[web])")
    w.add_argument("mesh", nargs="?", help=f"mesh to edit (default: {DEFAULT_MESH.name})")
    w.add_argument("--port", type=int, default=8080, help="port to serve on (default 8080)")
    w.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1: this machine only; use an ssh tunnel from another)")
    w.add_argument("--cage", "--cage-size", dest="cage", type=parse_cage_size, default=CAGE_SIZE,
                   help="cage vertices (2000) or fraction (0.05 or 5%%); default 5%%")
    w.add_argument("--edit", help="open with this edit file replayed (as the window's File > Load Edit)")
    w.set_defaults(func=run_web)
    return p


def version_text() -> str:
    """``hybridedit --version``: the version, the Python, and the sparse solver that runs."""
    import platform

    from . import __version__
    from .core.linsolve import available_backends, backend_description

    return (f"hybridedit {__version__} (Python {platform.python_version()}, {sys.platform})\n"
            f"solver: {backend_description()}; installed: {', '.join(available_backends())}")


class _Version(argparse.Action):
    """--version, its text made only when asked (the solver's packages load then, not at every start)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(version_text())
        parser.exit()


def build_open_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="hybridedit",
        description="Open the hybrid mesh editor (default mesh when no file is given). "
        "Subcommands: 'hybridedit deform -h', 'hybridedit batch -h', 'hybridedit info -h'.",
    )
    p.add_argument("--version", action=_Version, help="print the version and the sparse solver in use, and exit")
    p.add_argument("mesh", nargs="?", help="mesh to open (.obj .ply .stl .off .glb)")
    p.add_argument("--cage", type=parse_cage_size, default=CAGE_SIZE, help="cage vertices or fraction (default 5%%)")
    p.add_argument("--screenshot", help="render the scene to this PNG and exit")
    p.add_argument("-o", "--output", help=argparse.SUPPRESS)
    return p


def console_main() -> None:
    """The ``hybridedit`` command: :func:`main`, then the exit; after the window (or an off-screen
    render) without the interpreter's teardown of Qt and VTK (see :mod:`hybridedit.viewer.shutdown`)."""
    from .viewer.shutdown import leave, uses_window  # plain Python: no Qt or VTK imported

    status = main()
    if uses_window():
        leave(status)
    sys.exit(status)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    # a discarded cache entry is one of the engine's notes, printed as the others are (not twice)
    warnings.filterwarnings("ignore", message="hybridedit: cache entry")
    if argv and argv[0] in ("deform", "batch", "info", "web"):
        args = build_parser().parse_args(argv)
    else:
        args = build_open_parser().parse_args(argv)
        args.func = run_open
    _PROGRESS.clear()
    try:
        return _run(args)
    except (CLIError, MeshError, MeshFileError, EditFileError, SelectionError, WriteError,
            OutputPathError) as e:
        print(f"hybridedit: error: {one_line(e)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("hybridedit: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader went away (`hybridedit info FILE | head -1`): what it wanted was written; nothing more
        # is said, and the interpreter's last flush at exit must not fail on the closed pipe either
        _quiet_stdout()
        return 0
    except MemoryError:
        if os.environ.get("HYBRIDEDIT_DEBUG") == "1":
            raise
        print(f"hybridedit: error: {_input_name(args)}out of memory (try a smaller --cage)", file=sys.stderr)
        return 1
    except ValueError as e:  # a bad value that slipped past the checks above: still the user's input
        if os.environ.get("HYBRIDEDIT_DEBUG") == "1":
            raise
        print(f"hybridedit: error: {_input_name(args)}{one_line(e)}", file=sys.stderr)
        return 2
    except Exception as e:  # noqa: BLE001 -- one line, never a traceback (HYBRIDEDIT_DEBUG=1 shows it)
        if os.environ.get("HYBRIDEDIT_DEBUG") == "1":
            raise
        print(f"hybridedit: internal error: {_input_name(args)}{type(e).__name__}: {one_line(e)} "
              "(set HYBRIDEDIT_DEBUG=1 for the traceback)", file=sys.stderr)
        return 1


def _quiet_stdout() -> None:
    """Point standard output at the null device (its reader has closed the pipe)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


def _run(args: argparse.Namespace) -> int:
    """The subcommand; whatever it raises leaves no progress line open on the terminal (the error
    or traceback printed next starts on a line of its own)."""
    try:
        return args.func(args)
    except BaseException:
        _end_progress_lines()
        raise


def _input_name(args: argparse.Namespace) -> str:
    name = getattr(args, "input", None) or getattr(args, "mesh", None)
    return f"{Path(name).name}: " if name else ""


if __name__ == "__main__":
    sys.exit(main())
