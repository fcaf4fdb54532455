"""The JSON edit file: a selection plus a handle transform, replayable in batch."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .atomic import atomic_write
from .transforms import rigid_transform


class EditFileError(ValueError):
    """An edit file that cannot be used; the message names the file and the problem."""


@dataclass
class Edit:
    """A selection and a handle transform.

    Attributes
    ----------
    handle : (k,) int64 vertex indices
    fixed : (j,) int64 vertex indices or None
    roi : (r,) int64 vertex indices or None (everything outside it is fixed)
    space : "shape" or "cage", what the indices refer to
    translate : (3,) float64
    rotate : None or {"axis": [x, y, z], "degrees": a, "center": [x, y, z]}
    """

    handle: np.ndarray
    fixed: np.ndarray | None = None
    roi: np.ndarray | None = None
    space: str = "shape"
    translate: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotate: dict | None = None

    def transform(self, default_center: np.ndarray | None = None) -> np.ndarray:
        """The (4, 4) handle transform: rotation about its center, then translation."""
        if self.rotate is None:
            return rigid_transform(translate=self.translate)
        center = self.rotate.get("center")
        if center is None:
            center = default_center
        return rigid_transform(
            translate=self.translate,
            axis=self.rotate["axis"],
            degrees=self.rotate["degrees"],
            center=center,
        )

    def to_json(self) -> dict:
        d: dict = {"space": self.space, "handle": [int(i) for i in self.handle]}
        if self.fixed is not None:
            d["fixed"] = [int(i) for i in self.fixed]
        if self.roi is not None:
            d["roi"] = [int(i) for i in self.roi]
        d["translate"] = [float(x) for x in self.translate]
        if self.rotate is not None:
            r = {"axis": [float(x) for x in self.rotate["axis"]], "degrees": float(self.rotate["degrees"])}
            if self.rotate.get("center") is not None:
                r["center"] = [float(x) for x in self.rotate["center"]]
            d["rotate"] = r
        return d


_KEYS = {"handle", "fixed", "roi", "space", "translate", "rotate"}


def _indices(path: str, key: str, value) -> np.ndarray:
    if not isinstance(value, list) or not all(isinstance(i, int) and not isinstance(i, bool) for i in value):
        raise EditFileError(f"{path}: \"{key}\" must be a list of integer vertex indices")
    if any(i < 0 for i in value):
        raise EditFileError(f"{path}: \"{key}\" has negative vertex indices")
    return np.asarray(value, dtype=np.int64)


def _vector(path: str, key: str, value) -> np.ndarray:
    ok = isinstance(value, list) and len(value) == 3 and all(
        isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in value
    )
    if not ok:
        raise EditFileError(f"{path}: \"{key}\" must be a list of 3 finite numbers")
    return np.asarray(value, dtype=np.float64)


def parse_edit(data: object, path: str = "<edit>") -> Edit:
    """Validate decoded JSON and build an :class:`Edit`."""
    if not isinstance(data, dict):
        raise EditFileError(f"{path}: the edit must be a JSON object")
    unknown = set(data) - _KEYS
    if unknown:
        raise EditFileError(f"{path}: unknown keys {sorted(unknown)}; allowed: {sorted(_KEYS)}")
    if "handle" not in data:
        raise EditFileError(f"{path}: missing \"handle\" (a list of vertex indices)")
    if "fixed" in data and "roi" in data:
        raise EditFileError(f"{path}: give \"fixed\" or \"roi\", not both")
    space = data.get("space", "shape")
    if space not in ("shape", "cage"):
        raise EditFileError(f"{path}: \"space\" must be \"shape\" or \"cage\", got {space!r}")
    handle = _indices(path, "handle", data["handle"])
    if handle.size == 0:
        raise EditFileError(f"{path}: \"handle\" is empty")
    fixed = _indices(path, "fixed", data["fixed"]) if "fixed" in data else None
    roi = _indices(path, "roi", data["roi"]) if "roi" in data else None
    translate = _vector(path, "translate", data["translate"]) if "translate" in data else np.zeros(3)
    rotate = None
    if "rotate" in data:
        r = data["rotate"]
        if not isinstance(r, dict) or "axis" not in r or "degrees" not in r:
            raise EditFileError(f"{path}: \"rotate\" must be {{\"axis\": [x,y,z], \"degrees\": a, \"center\": [x,y,z]}}")
        extra = set(r) - {"axis", "degrees", "center"}
        if extra:
            raise EditFileError(f"{path}: unknown keys in \"rotate\": {sorted(extra)}")
        axis = _vector(path, "rotate.axis", r["axis"])
        if not np.any(axis):
            raise EditFileError(f"{path}: \"rotate.axis\" must not be zero")
        deg = r["degrees"]
        if not isinstance(deg, (int, float)) or isinstance(deg, bool) or not math.isfinite(deg):
            raise EditFileError(f"{path}: \"rotate.degrees\" must be a finite number")
        center = _vector(path, "rotate.center", r["center"]) if r.get("center") is not None else None
        rotate = {"axis": axis, "degrees": float(deg), "center": center}
    return Edit(handle=handle, fixed=fixed, roi=roi, space=space, translate=translate, rotate=rotate)


def load_edit(path: str | Path) -> Edit:
    """Read an edit file; raises :class:`EditFileError` naming the file on any problem."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise EditFileError(f"{p}: no such edit file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise EditFileError(f"{p}: cannot read the edit file ({e.__class__.__name__}: {e})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise EditFileError(f"{p}: not valid JSON (line {e.lineno}, column {e.colno}: {e.msg})") from None
    return parse_edit(data, str(p))


def save_edit(path: str | Path, edit: Edit) -> None:
    """Write an edit file atomically."""
    with atomic_write(Path(path), "w") as fh:
        json.dump(edit.to_json(), fh, indent=1)
        fh.write("\n")
