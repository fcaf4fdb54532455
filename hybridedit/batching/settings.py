"""What a batch is asked to do, checked once: :class:`PoseSettings` (how random poses are drawn and
judged) and :class:`BatchSettings` (the mode, the cage, the output format), with the key that tells a
re-run with the same arguments (:meth:`BatchSettings.key`).

Examples
--------
>>> s = BatchSettings(poses=4, seed=7)
>>> s.mode, s.poses, s.pose.max_degrees
('poses', 4, 45.0)
>>> s.key() == BatchSettings(poses=4, seed=7).key() != BatchSettings(poses=4, seed=8).key()
True
"""

from __future__ import annotations

import hashlib
import json
import numbers
from dataclasses import asdict, dataclass, field

from ..defaults import CAGE_SIZE, ITERATIONS, SETTLE_FRAMES, check_cage_size

__all__ = ["PoseSettings", "BatchSettings", "OUTPUT_EXTENSIONS", "PACK_FORMATS"]

#: the formats an output can be written in (``hybridedit deform``'s)
OUTPUT_EXTENSIONS = (".obj", ".ply", ".stl", ".off", ".glb")
#: the pose packs (one file per input holding all its poses): their extension by name
PACK_FORMATS = {"glb": ".glb", "usd": ".usdc"}


def _count(name: str, value, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or int(value) < least:
        raise ValueError(f"{name} must be a whole number >= {least}, got {value!r}")
    return int(value)


def _number(name: str, value, low: float, high: float) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (low < float(value) <= high):
        raise ValueError(f"{name} must be a number in ({low:g}, {high:g}], got {value!r}")
    return float(value)


@dataclass(frozen=True)
class PoseSettings:
    """How a random plausible pose is drawn and when it is redrawn.

    Parameters
    ----------
    max_degrees : float
        Largest rotation of a handle about its joint, in degrees (each angle is uniform in
        [-max_degrees, max_degrees]).
    max_stretch : float
        Largest edge stretch a pose may have, in percent of the edge's rest length
        (|l' - l| / l); a pose over it is redrawn.
    tries : int
        Draws made for one pose before it is recorded as failed.
    handles : int
        Most handles (limbs) one pose moves; each pose moves 1 to ``handles`` of them.
    min_move : float
        Least distance a pose moves the shape (its largest vertex displacement), in percent of its
        bounding-box diagonal, in [0, 100); a pose that moves less is redrawn (within ``tries``).
    iterations : int
        ARAP iterations run at a pose's transforms (the window's settle: 60).
    """

    max_degrees: float = 45.0
    max_stretch: float = 50.0
    tries: int = 8
    handles: int = 2
    min_move: float = 2.0
    iterations: int = SETTLE_FRAMES * ITERATIONS

    def __post_init__(self) -> None:
        object.__setattr__(self, "max_degrees", _number("max_degrees", self.max_degrees, 0.0, 180.0))
        object.__setattr__(self, "max_stretch", _number("max_stretch", self.max_stretch, 0.0, float("inf")))
        object.__setattr__(self, "tries", _count("tries", self.tries, 1))
        object.__setattr__(self, "handles", _count("handles", self.handles, 1))
        if isinstance(self.min_move, bool) or not isinstance(self.min_move, numbers.Real) \
                or not 0.0 <= float(self.min_move) < 100.0:
            raise ValueError(f"min_move must be a number in [0, 100), got {self.min_move!r}")
        object.__setattr__(self, "min_move", float(self.min_move))
        object.__setattr__(self, "iterations", _count("iterations", self.iterations, 1))


@dataclass(frozen=True)
class BatchSettings:
    """One batch's arguments (all keyword-only), checked (ValueError saying which and why).

    Parameters
    ----------
    poses : int or None
        Random poses per mesh (the poses mode), or None with ``edits``.
    edits : str or None
        A folder of edit files, one per mesh matched by name (the edits mode), or None.
    seed : int
        The seed every pose's random generator is derived from (with the input's content hash
        and the pose index).
    cage_size : int or float
        The cage of the poses mode (vertex count or fraction); an edit file replays on the cage
        it records.
    output_format : str or None
        Extension of the outputs (".ply", ...); None: each input's own.
    pack : str or None
        "glb" or "usd" (the poses mode): one file per input, ``<stem>-poses.glb`` (``.usdc``),
        holding all its poses as morph targets (blend shapes), instead of one mesh per pose.
    pose : PoseSettings
        How poses are drawn and judged.
    """

    poses: int | None = None
    edits: str | None = None
    seed: int = 0
    cage_size: int | float = CAGE_SIZE
    output_format: str | None = None
    pack: str | None = None
    pose: PoseSettings = field(default_factory=PoseSettings)

    def __post_init__(self) -> None:
        if (self.poses is None) == (self.edits is None):
            raise ValueError("give either poses (random poses per mesh) or edits (a folder of edit files)")
        if self.poses is not None:
            object.__setattr__(self, "poses", _count("poses", self.poses, 1))
        object.__setattr__(self, "seed", _count("seed", self.seed, 0))
        object.__setattr__(self, "cage_size", check_cage_size(self.cage_size))
        if self.output_format is not None:
            ext = str(self.output_format).lower()
            ext = ext if ext.startswith(".") else "." + ext
            if ext not in OUTPUT_EXTENSIONS:
                raise ValueError(f"output_format must be one of {', '.join(OUTPUT_EXTENSIONS)}, "
                                 f"got {self.output_format!r}")
            object.__setattr__(self, "output_format", ext)
        if self.pack is not None:
            name = str(self.pack).lower().lstrip(".")
            name = {"usdc": "usd"}.get(name, name)
            if name not in PACK_FORMATS:
                raise ValueError(f"pack must be one of {', '.join(PACK_FORMATS)}, got {self.pack!r}")
            if self.poses is None:
                raise ValueError("pack: for poses only (an edit file per mesh makes one output each)")
            if self.output_format is not None:
                raise ValueError("pack: give pack (one file of poses per input) or output_format (a file per "
                                 "pose), not both")
            object.__setattr__(self, "pack", name)
        if not isinstance(self.pose, PoseSettings):
            raise ValueError(f"pose must be a PoseSettings, got {type(self.pose).__name__}")

    @property
    def mode(self) -> str:
        """"poses" (random poses) or "edits" (an edit file per mesh)."""
        return "poses" if self.poses is not None else "edits"

    @property
    def pack_extension(self) -> str | None:
        """The packs' extension (".glb", ".usdc"), or None when every pose is a file of its own."""
        return None if self.pack is None else PACK_FORMATS[self.pack]

    def key(self) -> str:
        """16 hex digits naming what makes an output (mode, seed, cage, pose settings, format, pack): a
        manifest row made with another key is redone, not skipped."""
        what = asdict(self)
        what.pop("poses")  # the count does not change pose k
        what.pop("edits")  # (each edit file's own hash is checked)
        if self.mode == "edits":
            what.pop("pose")
            what.pop("seed")
            what.pop("cage_size")
            what.pop("pack")
        text = json.dumps({"mode": self.mode, **what}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]
