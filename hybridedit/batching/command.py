"""``hybridedit batch``: its arguments (:func:`add_parser`) and what it runs (:func:`run_batch`).

The command's exit statuses: 0 when every output is done, 1 when any failed (the manifest says
which and why), 2 for bad arguments (one line, raised as :class:`hybridedit.core.command_line.CLIError` and
printed by :func:`hybridedit.cli.main`, before any work).
"""

from __future__ import annotations

import argparse
import sys

from ..core.command_line import CLIError, one_line, parse_cage_size
from ..defaults import CAGE_SIZE

__all__ = ["add_parser", "run_batch"]

#: hybridedit batch's pose options, with their defaults (given with --edits, they are refused)
_POSE_OPTIONS = {"seed": 0, "max_degrees": 45.0, "max_stretch": 50.0, "min_move": 2.0, "tries": 8, "handles": 2,
                 "cage": CAGE_SIZE, "pack": None}


def run_batch(args: argparse.Namespace) -> int:
    """``hybridedit batch``: pose every input on a Dask cluster; exit status 0 when every output is
    done, 1 when any failed (the manifest says which and why), 2 for bad arguments."""
    settings = _batch_settings(args)
    if args.workers is not None and args.scheduler is not None:
        raise CLIError("give --workers (a local cluster) or --scheduler (a running one), not both")
    if args.workers is not None and args.workers < 1:
        raise CLIError(f"--workers must be >= 1, got {args.workers}")
    if args.retries < 0:
        raise CLIError(f"--retries must be >= 0, got {args.retries}")
    from .api import run
    from .cluster import ClusterError

    try:
        result = run(args.inputs, args.output, settings=settings, scheduler=args.scheduler, workers=args.workers,
                     retries=args.retries, progress=not args.quiet)
    except (ClusterError, ValueError) as e:  # InputError: an input that names nothing
        raise CLIError(one_line(e)) from None
    if not args.quiet:
        total = result.made + result.failed + result.skipped
        print(f"hybridedit: batch: {total} output{'s' if total != 1 else ''}: {result.made} made, "
              f"{result.skipped} done before, {result.failed} failed; manifest {result.manifest}", file=sys.stderr)
    return 1 if result.failed else 0


def _batch_settings(args: argparse.Namespace):
    """The batch's settings from its arguments (CLIError for a wrong combination or value)."""
    from .settings import BatchSettings, PoseSettings

    if (args.poses is None) == (args.edits is None):
        raise CLIError("give --poses N (random poses of each mesh) or --edits DIR (an edit file per mesh)")
    given = [name for name in _POSE_OPTIONS if getattr(args, name) is not None]
    if args.edits is not None and given:
        flags = ", ".join("--" + name.replace("_", "-") for name in given)
        raise CLIError(f"{flags}: for --poses only (an edit file replays on the cage it records)")
    if args.pack is not None and args.format is not None:
        raise CLIError("give --pack (one file of poses per input) or --format (a file per pose), not both")
    value = {name: default if getattr(args, name) is None else getattr(args, name)
             for name, default in _POSE_OPTIONS.items()}
    try:
        pose = PoseSettings(max_degrees=value["max_degrees"], max_stretch=value["max_stretch"], tries=value["tries"],
                            handles=value["handles"], min_move=value["min_move"])
        settings = BatchSettings(poses=args.poses, edits=args.edits, seed=value["seed"], cage_size=value["cage"],
                                 output_format=args.format, pack=value["pack"], pose=pose)
    except ValueError as e:  # "max_degrees must be ...": said with the option's name
        text = one_line(e)
        name = text.split(" ", 1)[0]
        flag = "--format" if name == "output_format" else "--" + name.replace("_", "-")
        raise CLIError(flag + text[len(name):] if name in (*_POSE_OPTIONS, "poses", "output_format") else text) from None
    if settings.pack == "usd" and args.scheduler is None:  # a local cluster: its workers import what we do
        try:
            import pxr.Usd  # noqa: F401
        except ImportError:
            raise CLIError("--pack usd: writing USD needs usd-core: pip install 'hybridedit[usd]'") from None
    return settings


def add_parser(sub) -> None:
    """Add the ``batch`` subcommand to the ``hybridedit`` parser's subparsers ``sub``."""
    b = sub.add_parser(
        "batch", help="pose many meshes on a Dask cluster (random plausible poses, or an edit file each)",
        description="Pose every input mesh on a Dask cluster: N random plausible poses each (--poses), or the "
                    "edit file given for each (--edits). Every output gets its edit file (hybridedit deform "
                    "MESH -o OUT --edit EDIT makes the same file) and a row in OUTDIR/manifest.parquet; a "
                    "re-run with the same arguments makes only what is not done yet. Exit status: 0 all "
                    "done, 1 some failed (the manifest says why), 2 bad arguments.")
    b.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="mesh files, folders (searched below for .obj .ply .stl .off .glb) or quoted glob patterns")
    b.add_argument("-o", "--output", required=True, metavar="OUTDIR",
                   help="output folder: the posed meshes, their edit files and manifest.parquet")
    mode = b.add_argument_group("what to make (one of)")
    mode.add_argument("--poses", type=int, metavar="N", help="N random plausible poses of each mesh")
    mode.add_argument("--edits", metavar="DIR",
                      help="replay the edit file DIR/STEM.json (or STEM.edit.json) on each mesh STEM.*")
    pose = b.add_argument_group("random poses (with --poses)")
    pose.add_argument("--seed", type=int, help="seed of every pose's random draw, with the mesh's content hash "
                      "and the pose index: the same seed makes the same files whatever the workers (default 0)")
    pose.add_argument("--max-degrees", type=float, metavar="DEG",
                      help="largest rotation of a limb about its joint, in degrees (default 45)")
    pose.add_argument("--max-stretch", type=float, metavar="PERCENT",
                      help="largest edge stretch of a pose kept, in percent of the edge's length; a pose over "
                           "it is drawn again (default 50)")
    pose.add_argument("--min-move", type=float, metavar="PERCENT",
                      help="least a pose moves the shape (its largest vertex displacement), in percent of its "
                           "bounding-box diagonal; a pose under it is drawn again (default 2)")
    pose.add_argument("--tries", type=int, help="draws of one pose before it is recorded as failed (default 8)")
    pose.add_argument("--handles", type=int, help="most limbs one pose moves (default 2)")
    pose.add_argument("--cage", type=parse_cage_size, help="cage vertices (2000) or fraction (0.05 or 5%%) the "
                      "poses are made on (default 5%%)")
    pose.add_argument("--pack", choices=("glb", "usd"), help="write one file per input holding all its poses, "
                      "STEM-poses.glb (glTF morph targets) or STEM-poses.usdc (USD blend shapes), instead of one "
                      "mesh per pose")
    run = b.add_argument_group("where it runs")
    run.add_argument("--workers", type=int, metavar="K",
                     help="worker processes of a local Dask cluster (default: the core count)")
    run.add_argument("--scheduler", metavar="ADDRESS",
                     help="run on a running Dask cluster instead (tcp://HOST:PORT, started with `dask "
                          "scheduler` and `dask worker ADDRESS`); its workers must see the input and output paths")
    run.add_argument("--retries", type=int, default=2,
                     help="times Dask reruns a task that raised (a lost worker's tasks are rerun elsewhere "
                          "anyway; default 2)")
    b.add_argument("--format", metavar="EXT", help="write the outputs in this format (.ply .obj .stl .off .glb; "
                   "default each input's own)")
    b.add_argument("-q", "--quiet", action="store_true", help="no progress line and no summary")
    b.set_defaults(func=run_batch)

