"""The JSON edit file: the steps that make a pose, replayable in batch.

Format (version 3)::

    {
     "format": "hybridedit-edit", "version": 3,
     "mesh": {"vertices": 43243, "faces": 86482, "topology": "…", "bbox": [...], "centroid": [...]},
     "steps": [
      {"cage": {"size": 0.05, "vertices": 2162},   # optional: the cage the step ran on
       "space": "shape",
       "roi": [...],                        # or "fixed": [...]; neither: nothing fixed
       "symmetry": "x",                     # optional: "x" | "y" | "z" | {"point": [...], "normal": [...]}
       "handles": [{"indices": [...], "translate": [x, y, z],
                    "rotate": {"axis": [x, y, z], "degrees": a, "center": [x, y, z]}}, ...],
       "iterations": 60,                    # optional: ARAP iterations at these transforms
       "converge": {"tolerance": 1e-6, "max_iterations": 10000},  # optional: then to the fixed point
       "polish": 37},                       # optional: full-resolution polish iterations after them
      {"continues": true,                   # the selection of the step before, from its polished pose
       "handles": [{"translate": [...], "rotate": {...}}, ...], "iterations": 60},
      ...
     ],
     "poses": [                             # optional: poses kept beside it (the window's Poses panel)
      {"name": "arm up", "steps": [...]},   # each: a name (unique) and steps as above, from the rest pose
      ...
     ]
    }

Each step sets its selection on the pose the steps before it made (the rest pose
for the first), which is the pose its transforms are measured from: successive
edits compose, as in the window. ``iterations`` is how many ARAP iterations ran at
the step's transforms (without it, the replayer's frames times iterations, or none
when the step converges); ``converge`` that the cage's ARAP then ran to its fixed point
at them (:meth:`hybridedit.HybridEditor.converge`: to ``tolerance`` of the diagonal, by
a rule, at most ``max_iterations``); ``polish`` how many full-resolution iterations followed (a count, never a time, so
that a replay gives the same pose on any machine). A step that ``continues`` keeps
the selection of the step before (the window's next drag after a polish) and gives
only its groups' transforms.

``poses`` are other poses of the same mesh, each replayed from the rest pose as the file's own
``steps`` are (:func:`load_edit_with_poses`); :func:`load_edit` (and ``hybridedit deform``) reads the
``steps`` only, so a file with poses replays to the pose it was saved at.

Versions 1 (top-level ``handle``, ``translate`` and ``rotate``) and 2 (one step's
keys at the top level, with ``handles``) still load, as one step.

``mesh`` fingerprints the mesh the edit was made on (vertex and face counts, a
hash of the faces, bounding box and centroid); replaying on another mesh is
refused. Indices are shape vertex indices, or cage vertex indices with
``"space": "cage"`` (tied to one cage: prefer shape space).
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .atomic import atomic_write
from ..defaults import CONVERGE_MAX_ITERATIONS
from ..core.fingerprint import shape_bytes
from ..core.transforms import decompose_rigid, rigid_transform

FORMAT = "hybridedit-edit"
VERSION = 3
#: Largest edit file read (bytes): indices of a 10M-vertex mesh fit many times over.
MAX_BYTES = 512 * 1024 * 1024


class EditFileError(ValueError):
    """An edit file that cannot be used; the message names the file and the problem."""


@dataclass
class HandleEdit:
    """One handle group: its vertices and its transform.

    Attributes
    ----------
    indices : (k,) int64 vertex indices
    translate : (3,) float64, applied after the rotation
    rotate : None or {"axis": (3,), "degrees": a, "center": (3,) or None}
    matrix : None or (4, 4) float64, a general affine transform (instead of the two above)
    """

    indices: np.ndarray
    translate: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotate: dict | None = None
    matrix: np.ndarray | None = None

    def transform(self, default_center: np.ndarray | None = None) -> np.ndarray:
        """The (4, 4) transform: rotation about its center, then translation."""
        if self.matrix is not None:
            return np.asarray(self.matrix, dtype=np.float64).copy()
        if self.rotate is None:
            return rigid_transform(translate=self.translate)
        center = self.rotate.get("center")
        return rigid_transform(translate=self.translate, axis=self.rotate["axis"], degrees=self.rotate["degrees"],
                               center=default_center if center is None else center)

    @classmethod
    def from_matrix(cls, indices: np.ndarray, T: np.ndarray, *, center: np.ndarray) -> "HandleEdit":
        """Describe ``T`` as a rotation about ``center`` then a translation (a general
        affine ``T`` is kept as a matrix)."""
        T = np.asarray(T, dtype=np.float64)
        idx = np.asarray(indices, dtype=np.int64)
        try:
            translate, rotate = decompose_rigid(T, center)
        except ValueError:  # not rigid: kept as it is
            return cls(idx, matrix=T.copy())
        return cls(idx, translate=translate, rotate=rotate)

    def to_json(self) -> dict:
        d: dict = {"indices": [int(i) for i in self.indices]}
        if self.matrix is not None:
            d["matrix"] = [[float(x) for x in row] for row in self.matrix]
            return d
        d["translate"] = [float(x) for x in self.translate]
        if self.rotate is not None:
            r = {"axis": [float(x) for x in self.rotate["axis"]], "degrees": float(self.rotate["degrees"])}
            if self.rotate.get("center") is not None:
                r["center"] = [float(x) for x in self.rotate["center"]]
            d["rotate"] = r
        return d


class Edit:
    """The steps that make a pose: the last step's selection and handle transforms, and
    the steps before it (:attr:`before`).

    Parameters
    ----------
    handle : (k,) int array, optional
        The one handle group of a single-handle edit (with ``translate`` and ``rotate``).
    fixed : (j,) int array or None
        Vertices that stay.
    roi : (r,) int array or None
        Alternatively, everything outside it (and the handles) stays.
    space : "shape" or "cage", what the indices refer to.
    translate, rotate : the transform of ``handle`` (see :class:`HandleEdit`).
    handles : list of HandleEdit, optional
        Several handle groups (instead of ``handle``).
    symmetry : None, "x", "y", "z" or {"point": (3,), "normal": (3,)}
    mesh : dict or None
        Fingerprint of the mesh the edit was made on (:func:`mesh_fingerprint`).
    iterations : int or None
        ARAP iterations run at the transforms (None: as many as the replayer runs by default).
    polish : int or None
        Full-resolution polish iterations after them (None: no polish).
    converge : dict or None
        ``{"tolerance": t, "max_iterations": k}``: after the iterations, the cage's ARAP run to
        its fixed point at the transforms (None: not).
    cage : dict or None
        ``{"size": int count or float fraction, "vertices": c}``: the cage the step ran on.
    continues : bool
        The step keeps the selection of the step before it (its handles' indices are
        that step's), from the pose that step's polish made.
    before : sequence of Edit
        The steps before this one, oldest first (their ``mesh`` and ``before`` are unused).
    """

    def __init__(self, handle=None, fixed=None, roi=None, space: str = "shape", translate=None, rotate=None, *,
                 handles: list[HandleEdit] | None = None, symmetry=None, mesh: dict | None = None,
                 iterations: int | None = None, polish: int | None = None, cage: dict | None = None,
                 continues: bool = False, before=(), converge: dict | None = None) -> None:
        if handles is None:
            if handle is None:
                raise ValueError("an edit needs a handle or handles")
            handles = [HandleEdit(np.asarray(handle, dtype=np.int64),
                                  np.zeros(3) if translate is None else np.asarray(translate, dtype=np.float64),
                                  rotate)]
        elif handle is not None or translate is not None or rotate is not None:
            raise ValueError("give handles, or handle with translate/rotate, not both")
        for name, v in (("iterations", iterations), ("polish", polish)):
            if v is not None and (not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < 0):
                raise ValueError(f"{name} must be a count >= 0 or None, got {v!r}")
        self.handles = list(handles)
        self.fixed = None if fixed is None else np.asarray(fixed, dtype=np.int64)
        self.roi = None if roi is None else np.asarray(roi, dtype=np.int64)
        self.space = space
        self.symmetry = symmetry
        self.mesh = mesh
        self.iterations = None if iterations is None else int(iterations)
        self.polish = None if polish is None else int(polish)
        self.cage = cage
        self.converge = None if converge is None else _converge_spec("<edit>", "converge", converge, ValueError)
        self.continues = bool(continues)
        self.before = tuple(before)

    @property
    def steps(self) -> list["Edit"]:
        """Every step, oldest first: :attr:`before`, then this one."""
        return [*self.before, self]

    # the single-handle view of version 1
    @property
    def handle(self) -> np.ndarray:
        """Vertices of handle group 0."""
        return self.handles[0].indices

    @property
    def translate(self) -> np.ndarray:
        return self.handles[0].translate

    @property
    def rotate(self) -> dict | None:
        return self.handles[0].rotate

    def transform(self, default_center: np.ndarray | None = None) -> np.ndarray:
        """The (4, 4) transform of handle group 0."""
        return self.handles[0].transform(default_center)

    def step_json(self) -> dict:
        """This step alone as an edit file's step (an entry of ``to_json()["steps"]``)."""
        d: dict = {}
        if self.cage is not None:
            d["cage"] = dict(self.cage)
        if self.continues:
            d["continues"] = True
            d["handles"] = [{k: v for k, v in h.to_json().items() if k != "indices"} for h in self.handles]
        else:
            d["space"] = self.space
            if self.fixed is not None:
                d["fixed"] = [int(i) for i in self.fixed]
            if self.roi is not None:
                d["roi"] = [int(i) for i in self.roi]
            if self.symmetry is not None:
                d["symmetry"] = _symmetry_json(self.symmetry)
            d["handles"] = [h.to_json() for h in self.handles]
        if self.iterations is not None:
            d["iterations"] = self.iterations
        if self.converge is not None:
            d["converge"] = {"tolerance": float(self.converge["tolerance"]),
                             "max_iterations": int(self.converge["max_iterations"])}
        if self.polish is not None:
            d["polish"] = self.polish
        return d

    def to_json(self) -> dict:
        return steps_document([step.step_json() for step in self.steps], self.mesh)


def steps_document(steps: list[dict], mesh: dict | None = None) -> dict:
    """An edit file's JSON made of its steps' (:meth:`Edit.step_json`'s) and the mesh's fingerprint
    (:func:`mesh_fingerprint`; None: none)."""
    d: dict = {"format": FORMAT, "version": VERSION}
    if mesh is not None:
        d["mesh"] = mesh
    d["steps"] = steps
    return d


def _symmetry_json(s):
    """A symmetry as JSON: an axis name, or {"point": [...], "normal": [...]} for a (point, normal) pair."""
    if isinstance(s, (tuple, list)) and len(s) == 2:
        return {"point": [float(x) for x in s[0]], "normal": [float(x) for x in s[1]]}
    return s


def mesh_fingerprint(mesh) -> dict:
    """Vertex and face counts, a hash of the faces, bounding box and centroid of ``mesh`` (the hash:
    of the faces' :func:`~hybridedit.core.fingerprint.shape_bytes`, 16 hex digits, as edit files
    have always stored it)."""
    _, v, f = shape_bytes(mesh.vertices, mesh.faces)
    return {
        "vertices": int(len(v)),
        "faces": int(len(f)),
        "topology": hashlib.sha256(f).hexdigest()[:16],
        "bbox": [float(x) for x in np.concatenate([v.min(axis=0), v.max(axis=0)])] if len(v) else [],
        "centroid": [float(x) for x in v.mean(axis=0)] if len(v) else [],
    }


#: Fingerprints agree when bounding box and centroid match to this fraction of the diagonal.
FINGERPRINT_TOLERANCE = 1e-5


def check_mesh(edit: Edit, mesh, path: str) -> None:
    """Refuse (EditFileError naming ``path``) an edit made for another mesh."""
    fp = edit.mesh
    if fp is None:
        return
    here = mesh_fingerprint(mesh)
    if (fp.get("vertices"), fp.get("faces")) != (here["vertices"], here["faces"]):
        raise EditFileError(
            f"{path}: made for a mesh of {fp.get('vertices'):,} vertices and {fp.get('faces'):,} faces; "
            f"this one has {here['vertices']:,} and {here['faces']:,}: refused")
    if fp.get("topology") != here["topology"]:
        raise EditFileError(f"{path}: made for another mesh (same size, different faces): refused")
    try:
        a = np.asarray(fp.get("bbox", []) + fp.get("centroid", []), dtype=np.float64)
    except (TypeError, ValueError):
        raise EditFileError(f"{path}: \"mesh\" fingerprint is malformed") from None
    b = np.asarray(here["bbox"] + here["centroid"])
    diag = float(np.linalg.norm(b[3:6] - b[:3])) or 1.0
    if a.shape != b.shape or not np.all(np.abs(a - b) <= FINGERPRINT_TOLERANCE * diag):
        raise EditFileError(f"{path}: made for another mesh (same faces, vertices elsewhere): refused")


_KEYS_V1 = {"handle", "fixed", "roi", "space", "translate", "rotate"}
_KEYS_V2 = {"format", "version", "mesh", "space", "fixed", "roi", "symmetry", "handles"}
_KEYS_V3 = {"format", "version", "mesh", "steps", "poses"}
_POSE_KEYS = {"name", "steps"}
_STEP_KEYS = {"cage", "space", "fixed", "roi", "symmetry", "handles", "iterations", "polish", "continues",
              "converge"}

_HANDLE_KEYS = {"indices", "translate", "rotate", "matrix"}
#: Most steps an edit file may hold (each is a selection and a solve to replay).
MAX_STEPS = 10000


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _indices(path: str, key: str, value) -> np.ndarray:
    if not isinstance(value, list) or not all(isinstance(i, int) and not isinstance(i, bool) for i in value):
        raise EditFileError(f"{path}: \"{key}\" must be a list of integer vertex indices")
    if any(i < 0 for i in value):
        raise EditFileError(f"{path}: \"{key}\" has negative vertex indices")
    big = next((i for i in value if i >= 2 ** 62), None)
    if big is not None:
        raise EditFileError(f"{path}: \"{key}\" has a vertex index far beyond any mesh ({big:.3g})")
    return np.asarray(value, dtype=np.int64)


def _known_keys(path: str, d: dict, allowed, key: str = "", allowed_in: str = "") -> None:
    """Refuse (EditFileError) an object ``d`` (at ``key``; the top level: "") with keys not in
    ``allowed``, naming them and the ones allowed."""
    unknown = set(d) - set(allowed)
    if unknown:
        where = f" in \"{key}\":" if key else ""
        raise EditFileError(f"{path}: unknown keys{where} {sorted(unknown)}; allowed{allowed_in}: {sorted(allowed)}")


def _vector(path: str, key: str, value) -> np.ndarray:
    if not (isinstance(value, list) and len(value) == 3 and all(_is_number(x) for x in value)):
        raise EditFileError(f"{path}: \"{key}\" must be a list of 3 finite numbers")
    return np.asarray(value, dtype=np.float64)


def _rotate(path: str, key: str, r) -> dict:
    if not isinstance(r, dict) or "axis" not in r or "degrees" not in r:
        raise EditFileError(f"{path}: \"{key}\" must be {{\"axis\": [x,y,z], \"degrees\": a, \"center\": [x,y,z]}}")
    _known_keys(path, r, {"axis", "degrees", "center"}, key)
    axis = _vector(path, f"{key}.axis", r["axis"])
    if not np.any(axis):
        raise EditFileError(f"{path}: \"{key}.axis\" must not be zero")
    if not _is_number(r["degrees"]):
        raise EditFileError(f"{path}: \"{key}.degrees\" must be a finite number")
    center = _vector(path, f"{key}.center", r["center"]) if r.get("center") is not None else None
    return {"axis": axis, "degrees": float(r["degrees"]), "center": center}


def _handle(path: str, k: int, h, inherited: np.ndarray | None = None, prefix: str = "") -> HandleEdit:
    """Handle group ``k``; with ``inherited`` (a step that continues the one before) its indices are
    those and the group gives none."""
    key = f"{prefix}handles[{k}]"
    if not isinstance(h, dict):
        raise EditFileError(f"{path}: \"{key}\" must be an object with \"indices\"")
    _known_keys(path, h, _HANDLE_KEYS, key)
    if inherited is not None:
        if "indices" in h:
            raise EditFileError(f"{path}: \"{key}\" gives \"indices\" in a step that continues the one before "
                                "(it keeps that step's selection)")
        idx = inherited
    elif "indices" not in h:
        raise EditFileError(f"{path}: \"{key}\" has no \"indices\"")
    else:
        idx = _indices(path, f"{key}.indices", h["indices"])
    if idx.size == 0:
        raise EditFileError(f"{path}: \"{key}.indices\" is empty")
    if "matrix" in h:
        if "translate" in h or "rotate" in h:
            raise EditFileError(f"{path}: \"{key}\": give \"matrix\", or \"translate\"/\"rotate\", not both")
        m = h["matrix"]
        ok = isinstance(m, list) and len(m) == 4 and all(
            isinstance(row, list) and len(row) == 4 and all(_is_number(x) for x in row) for row in m)
        if not ok or not np.allclose(np.asarray(m, dtype=np.float64)[3], [0, 0, 0, 1]):
            raise EditFileError(f"{path}: \"{key}.matrix\" must be a 4x4 affine matrix (last row 0 0 0 1)")
        return HandleEdit(idx, matrix=np.asarray(m, dtype=np.float64))
    t = _vector(path, f"{key}.translate", h["translate"]) if "translate" in h else np.zeros(3)
    r = _rotate(path, f"{key}.rotate", h["rotate"]) if "rotate" in h else None
    return HandleEdit(idx, t, r)


def _symmetry(path: str, s):
    if s is None or s in ("x", "y", "z"):
        return s
    if isinstance(s, dict) and set(s) == {"point", "normal"}:
        p, n = _vector(path, "symmetry.point", s["point"]), _vector(path, "symmetry.normal", s["normal"])
        if not np.any(n):
            raise EditFileError(f"{path}: \"symmetry.normal\" must not be zero")
        return (p, n)
    raise EditFileError(f"{path}: \"symmetry\" must be \"x\", \"y\", \"z\" or {{\"point\": [...], \"normal\": [...]}}")


def _mesh(path: str, m) -> dict:
    ok = isinstance(m, dict) and all(isinstance(m.get(k), int) and not isinstance(m.get(k), bool)
                                     for k in ("vertices", "faces")) and isinstance(m.get("topology"), str)
    if not ok:
        raise EditFileError(f"{path}: \"mesh\" must hold \"vertices\", \"faces\" and \"topology\" of the mesh")
    for k in ("bbox", "centroid"):
        if not (isinstance(m.get(k, []), list) and all(_is_number(x) for x in m.get(k, []))):
            raise EditFileError(f"{path}: \"mesh.{k}\" must be a list of numbers")
    return m


def _count(path: str, key: str, value) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or value < 0 or value > 10 ** 9:
        raise EditFileError(f"{path}: \"{key}\" must be a whole number of iterations (0 to 10^9), got {value!r}")
    return int(value)


def _converge_spec(path: str, key: str, c, error=EditFileError) -> dict:
    """A step's ``converge``: ``{"tolerance": t > 0, "max_iterations": k >= 1 (optional)}``."""
    ok = isinstance(c, dict) and "tolerance" in c and set(c) <= {"tolerance", "max_iterations"} \
        and _is_number(c["tolerance"]) and c["tolerance"] > 0
    cap = c.get("max_iterations", CONVERGE_MAX_ITERATIONS) if ok else None
    if not ok or not isinstance(cap, (int, np.integer)) or isinstance(cap, bool) or not 1 <= cap <= 10 ** 9:
        raise error(f"{path}: \"{key}\" must be {{\"tolerance\": a number > 0, \"max_iterations\": 1 to 10^9}}")
    return {"tolerance": float(c["tolerance"]), "max_iterations": int(cap)}


def _cage(path: str, key: str, c) -> dict:
    ok = isinstance(c, dict) and set(c) == {"size", "vertices"} and isinstance(c["vertices"], int) \
        and not isinstance(c["vertices"], bool) and c["vertices"] >= 4 and _is_number(c["size"]) and c["size"] > 0
    if not ok:
        raise EditFileError(f"{path}: \"{key}\" must be {{\"size\": count or fraction, \"vertices\": count}}")
    size = c["size"]
    return {"size": size if isinstance(size, int) else float(size), "vertices": int(c["vertices"])}


def _selection(path: str, data: dict, prefix: str = "") -> dict:
    """The selection keys of a step (version 2's top level): fixed or roi, space, symmetry."""
    if "fixed" in data and "roi" in data:
        raise EditFileError(f"{path}: {prefix}give \"fixed\" or \"roi\", not both")
    space = data.get("space", "shape")
    if space not in ("shape", "cage"):
        raise EditFileError(f"{path}: {prefix}\"space\" must be \"shape\" or \"cage\", got {space!r}")
    return {"fixed": _indices(path, f"{prefix}fixed", data["fixed"]) if "fixed" in data else None,
            "roi": _indices(path, f"{prefix}roi", data["roi"]) if "roi" in data else None,
            "space": space, "symmetry": _symmetry(path, data.get("symmetry"))}


def _step(path: str, k: int, d, previous: Edit | None, prefix: str = "") -> Edit:
    """Step ``k`` of a version 3 file (``previous``: the step before it, or None; ``prefix``: where the
    steps are, for messages: "" for the file's own, ``poses[i].`` for a kept pose's)."""
    where = f"{prefix}steps[{k}]."
    if not isinstance(d, dict):
        raise EditFileError(f"{path}: \"{prefix}steps[{k}]\" must be an object (a selection and its handles)")
    _known_keys(path, d, _STEP_KEYS, f"{prefix}steps[{k}]")
    continues = d.get("continues", False)
    if not isinstance(continues, bool):
        raise EditFileError(f"{path}: \"{where}continues\" must be true or false")
    hs = d.get("handles")
    if not isinstance(hs, list) or not hs:
        raise EditFileError(f"{path}: \"{where}handles\" must be a non-empty list of handle groups")
    extra = {"iterations": _count(path, where + "iterations", d["iterations"]) if "iterations" in d else None,
             "polish": _count(path, where + "polish", d["polish"]) if "polish" in d else None,
             "cage": _cage(path, where + "cage", d["cage"]) if "cage" in d else None,
             "converge": _converge_spec(path, where + "converge", d["converge"]) if "converge" in d else None}
    if continues:
        if previous is None:
            raise EditFileError(f"{path}: \"{prefix}steps[0]\" cannot continue a step before it: there is none")
        given = sorted({"space", "fixed", "roi", "symmetry"} & set(d))
        if given:
            raise EditFileError(f"{path}: \"{prefix}steps[{k}]\" continues the step before (its selection) and gives "
                                f"{given}: give either")
        if len(hs) != len(previous.handles):
            raise EditFileError(f"{path}: \"{where}handles\" has {len(hs)} groups; the step it continues has "
                                f"{len(previous.handles)}")
        handles = [_handle(path, g, h, previous.handles[g].indices, where) for g, h in enumerate(hs)]
        return Edit(handles=handles, fixed=previous.fixed, roi=previous.roi, space=previous.space,
                    symmetry=previous.symmetry, continues=True, **extra)
    handles = [_handle(path, g, h, None, where) for g, h in enumerate(hs)]
    return Edit(handles=handles, **_selection(path, d, where), **extra)


def parse_edit(data: object, path: str = "<edit>") -> Edit:
    """Validate decoded JSON (any version) and build an :class:`Edit`."""
    if not isinstance(data, dict):
        raise EditFileError(f"{path}: the edit must be a JSON object")
    if "steps" in data or data.get("version") == 3:
        return _parse_v3(data, path)
    v2 = "handles" in data or "format" in data
    allowed = _KEYS_V2 if v2 else _KEYS_V1
    _known_keys(path, data, allowed)
    if v2:
        _check_header(data, path)
        if "handles" not in data:
            raise EditFileError(f"{path}: missing \"handles\" (a list of handle groups)")
    elif "handle" not in data:
        raise EditFileError(f"{path}: missing \"handle\" (a list of vertex indices)")
    sel = _selection(path, data)
    if v2:
        hs = data["handles"]
        if not isinstance(hs, list) or not hs:
            raise EditFileError(f"{path}: \"handles\" must be a non-empty list of handle groups")
        handles = [_handle(path, k, h) for k, h in enumerate(hs)]
        return Edit(handles=handles, mesh=_mesh(path, data["mesh"]) if "mesh" in data else None, **sel)
    handle = _indices(path, "handle", data["handle"])
    if handle.size == 0:
        raise EditFileError(f"{path}: \"handle\" is empty")
    translate = _vector(path, "translate", data["translate"]) if "translate" in data else np.zeros(3)
    rotate = _rotate(path, "rotate", data["rotate"]) if "rotate" in data else None
    sel.pop("symmetry")
    return Edit(handle=handle, translate=translate, rotate=rotate, **sel)


def _check_header(data: dict, path: str) -> None:
    if data.get("format", FORMAT) != FORMAT:
        raise EditFileError(f"{path}: \"format\" must be \"{FORMAT}\"")
    ver = data.get("version", VERSION)
    if not isinstance(ver, int) or isinstance(ver, bool) or ver > VERSION or ver < 1:
        raise EditFileError(f"{path}: edit file version {ver!r} is not one this hybridedit reads (1 to {VERSION})")


def _parse_v3(data: dict, path: str) -> Edit:
    _known_keys(path, data, _KEYS_V3, allowed_in=" in version 3")
    _check_header(data, path)
    if data.get("version", VERSION) != 3:
        raise EditFileError(f"{path}: \"steps\" is a version 3 key; this file says version {data.get('version')}")
    return _steps(path, data.get("steps"), _mesh(path, data["mesh"]) if "mesh" in data else None)


def _steps(path: str, raw, mesh: dict | None, prefix: str = "") -> Edit:
    """The :class:`Edit` of a version 3 list of steps (at ``prefix``, for messages), made on ``mesh``."""
    if not isinstance(raw, list) or not raw:
        raise EditFileError(f"{path}: \"{prefix}steps\" must be a non-empty list of steps")
    if len(raw) > MAX_STEPS:
        raise EditFileError(f"{path}: {len(raw):,} steps{' in ' + prefix[:-1] if prefix else ''}; "
                            f"more than {MAX_STEPS:,} is refused")
    steps: list[Edit] = []
    for k, d in enumerate(raw):
        steps.append(_step(path, k, d, steps[-1] if steps else None, prefix))
    last = steps[-1]
    last.before = tuple(steps[:-1])
    last.mesh = mesh
    return last


def parse_poses(data: object, path: str = "<edit>") -> list[tuple[str, Edit]]:
    """The poses kept in decoded edit-file JSON: ``[(name, edit), ...]`` in the file's order (none
    for a file without ``poses``, or of version 1 or 2). Each edit replays from the rest pose and
    carries the file's ``mesh`` fingerprint.

    Raises
    ------
    EditFileError
        The file itself is not an edit (:func:`parse_edit`), or ``poses`` is malformed: not a list of
        ``{"name": text, "steps": [...]}``, a name empty or given twice, a step that is not one.
    """
    main = parse_edit(data, path)
    raw = data.get("poses") if isinstance(data, dict) else None
    return [] if raw is None else parse_pose_list(raw, path, main.mesh)


def parse_pose_list(raw: object, path: str = "<edit>", mesh: dict | None = None) -> list[tuple[str, Edit]]:
    """A ``poses`` list (:func:`pose_list_json`) as ``[(name, edit), ...]``, each edit made on ``mesh``
    (a fingerprint, or None); raises :class:`EditFileError` as :func:`parse_poses`."""
    if not isinstance(raw, list):
        raise EditFileError(f"{path}: \"poses\" must be a list of {{\"name\": ..., \"steps\": [...]}}")
    out: list[tuple[str, Edit]] = []
    seen: set[str] = set()
    for i, d in enumerate(raw):
        where = f"poses[{i}]"
        if not isinstance(d, dict):
            raise EditFileError(f"{path}: \"{where}\" must be an object with \"name\" and \"steps\"")
        _known_keys(path, d, _POSE_KEYS, where)
        name = d.get("name")
        if not isinstance(name, str) or not name.strip():
            raise EditFileError(f"{path}: \"{where}.name\" must be a non-empty text")
        if name in seen:
            raise EditFileError(f"{path}: \"{where}.name\": the name {name!r} is given twice")
        seen.add(name)
        out.append((name, _steps(path, d.get("steps"), mesh, f"{where}.")))
    return out


def load_edit(path: str | Path) -> Edit:
    """Read an edit file (the pose it was saved at: its ``steps``); raises :class:`EditFileError` naming
    the file on any problem."""
    return parse_edit(_read_json(path), str(Path(path)))


def load_edit_with_poses(path: str | Path) -> tuple[Edit, list[tuple[str, Edit]]]:
    """Read an edit file and the poses kept in it: ``(edit, [(name, pose's edit), ...])`` (no poses
    for a file without them); raises :class:`EditFileError` naming the file on any problem."""
    data = _read_json(path)
    return parse_edit(data, str(Path(path))), parse_poses(data, str(Path(path)))


def _read_json(path: str | Path) -> object:
    """The decoded JSON of an edit file; :class:`EditFileError` naming it when it cannot be read."""
    p = Path(path)
    try:
        if p.is_file() and p.stat().st_size > MAX_BYTES:
            raise EditFileError(f"{p}: the edit file is {p.stat().st_size / 2**20:.0f} MB; "
                                f"more than {MAX_BYTES // 2**20} MB is refused")
        text = p.read_text(encoding="utf-8-sig")  # a byte-order mark is text, not an error
    except FileNotFoundError:
        raise EditFileError(f"{p}: no such edit file") from None
    except IsADirectoryError:
        raise EditFileError(f"{p}: is a folder, not an edit file") from None
    except UnicodeDecodeError as e:
        raise EditFileError(f"{p}: not UTF-8 text (byte {e.start}): not an edit file") from None
    except OSError as e:
        raise EditFileError(f"{p}: cannot read the edit file ({e.strerror or e})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise EditFileError(f"{p}: not valid JSON (line {e.lineno}, column {e.colno}: {e.msg})") from None
    except RecursionError:
        raise EditFileError(f"{p}: JSON nested too deeply to be an edit file") from None
    except ValueError as e:  # e.g. an integer with more digits than Python reads
        raise EditFileError(f"{p}: not a usable JSON file ({' '.join(str(e).split())})") from None
    return data


def edit_json(edit: Edit, poses: Sequence[tuple[str, Edit]] = ()) -> dict:
    """The JSON of an edit file: ``edit``'s, and ``poses`` (``[(name, edit), ...]``, names unique)
    kept beside it as ``"poses"`` (none given: no such key, the file as before)."""
    d = edit.to_json()
    if poses:
        d["poses"] = pose_list_json(poses)
    return d


def pose_list_json(poses: Sequence[tuple[str, Edit]]) -> list[dict]:
    """``[{"name": name, "steps": [...]}, ...]`` of ``poses`` (``[(name, edit), ...]``, names unique and
    not empty: else ValueError), as an edit file keeps them."""
    names = [n for n, _ in poses]
    if len(set(names)) != len(names) or not all(isinstance(n, str) and n.strip() for n in names):
        raise ValueError(f"pose names must be non-empty and unique, got {names}")
    return [{"name": n, "steps": [st.step_json() for st in e.steps]} for n, e in poses]


def save_edit(path: str | Path, edit: Edit, *, poses: Sequence[tuple[str, Edit]] = ()) -> None:
    """Write an edit file atomically: ``edit``, and the ``poses`` (``[(name, edit), ...]``) kept beside
    it (:func:`load_edit_with_poses` reads them back; :func:`load_edit` and ``hybridedit deform`` the edit)."""
    data = edit_json(edit, poses)
    with atomic_write(Path(path), "w") as fh:
        json.dump(data, fh, indent=1)
        fh.write("\n")
