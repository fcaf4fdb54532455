"""A closed step of a pose record kept small: its vertex index lists packed (:class:`PackedStep`).

The record of how a pose was made keeps every step since the rest pose (:mod:`~hybridedit.deform.pose_record`),
so a long session keeps thousands: as int64 lists, a selection of a fifth of the creature (100K
vertices) is 295 KB a step (290 MB in 1,000 steps). A sorted list of distinct indices is kept as a
bit mask over ``[0, last]``, compressed (a region is a few runs of a mesh's vertex order: 3 KB a
step there); any other list as it is. Unpacking gives the lists back exactly.

A packed step also has a JSON form (:meth:`PackedStep.to_json`): an edit file's step with each index
list as its packed bytes in base64, which :func:`unpack_step_json` turns back into the edit file's
own form. A long session's recovery file is written in it (every step, after every change): the
steps need not be unpacked into int64 lists and then Python ints to be written (a megabyte of
short-lived memory a step on the creature, each write).
"""

from __future__ import annotations

import base64
import binascii
import copy
import dataclasses
import zlib
from dataclasses import dataclass

import numpy as np

from ..fileio.editfile import Edit

__all__ = ["PackedIndices", "PackedStep", "unpack_step_json"]

_NONE = np.zeros(0, dtype=np.int64)


@dataclass(frozen=True)
class PackedIndices:
    """A (k,) int64 index list packed: ``mask`` True when ``data`` is the zlib-compressed bit mask of
    a sorted list of distinct indices over ``[0, size)``, else the list's own int64 bytes."""

    data: bytes
    size: int
    mask: bool

    @classmethod
    def of(cls, indices: np.ndarray) -> "PackedIndices":
        a = np.ascontiguousarray(indices, dtype=np.int64)
        if a.size and a[0] >= 0 and np.all(a[1:] > a[:-1]):
            bits = np.zeros(int(a[-1]) + 1, dtype=bool)
            bits[a] = True
            return cls(zlib.compress(np.packbits(bits).tobytes(), 1), bits.size, True)
        return cls(a.tobytes(), a.size, False)

    def unpack(self) -> np.ndarray:
        """The (k,) int64 list, as it was given."""
        if not self.mask:
            return np.frombuffer(self.data, dtype=np.int64).copy()
        bits = np.unpackbits(np.frombuffer(zlib.decompress(self.data), dtype=np.uint8), count=self.size)
        return np.flatnonzero(bits).astype(np.int64)

    @property
    def nbytes(self) -> int:
        """The memory it holds, bytes (what :func:`~hybridedit.core.held_bytes.held_buffers` counts)."""
        return len(self.data)

    def to_json(self) -> dict:
        """``{"packed": base64 of data, "size": size, "mask": mask}`` (:meth:`from_json` reads it)."""
        return {"packed": base64.b64encode(self.data).decode("ascii"), "size": self.size, "mask": self.mask}

    @classmethod
    def from_json(cls, d: dict) -> "PackedIndices":
        """The packed list :meth:`to_json` wrote; ValueError when ``d`` is not one."""
        if not isinstance(d, dict) or not isinstance(d.get("packed"), str) or not isinstance(d.get("mask"), bool) \
                or not isinstance(d.get("size"), int) or isinstance(d.get("size"), bool) or d["size"] < 0:
            raise ValueError("a packed index list is {packed, size, mask}")
        try:
            data = base64.b64decode(d["packed"].encode("ascii"), validate=True)
        except (binascii.Error, UnicodeEncodeError) as e:
            raise ValueError(f"a packed index list's bytes are not base64 ({e})") from None
        out = cls(data, d["size"], d["mask"])
        if not out.mask and len(data) != 8 * out.size:
            raise ValueError("a packed index list's bytes do not hold its size")
        return out

    def unpack_checked(self) -> np.ndarray:
        """:meth:`unpack`, with ValueError for bytes that do not unpack (a damaged file)."""
        try:
            a = self.unpack()
        except zlib.error as e:
            raise ValueError(f"a packed index list does not unpack ({e})") from None
        if self.mask and (not a.size or a[-1] != self.size - 1):
            raise ValueError("a packed index list does not hold its size")
        return a


def _packed(indices: np.ndarray | None) -> PackedIndices | None:
    return None if indices is None else PackedIndices.of(indices)


def _unpacked(p: PackedIndices | None) -> np.ndarray | None:
    return None if p is None else p.unpack()


@dataclass(frozen=True)
class PackedStep:
    """One step of a record (an :class:`~hybridedit.fileio.editfile.Edit` with no steps before it), its
    index lists packed (:class:`PackedIndices`): ``bare`` is the step without them, ``handles`` the packed
    indices of each handle group, ``fixed`` and ``roi`` those lists packed (None where the step has none)."""

    bare: Edit
    handles: tuple[PackedIndices, ...]
    fixed: PackedIndices | None
    roi: PackedIndices | None

    @classmethod
    def of(cls, step: Edit) -> "PackedStep":
        bare = copy.copy(step)
        bare.handles = [dataclasses.replace(h, indices=_NONE) for h in step.handles]
        bare.fixed = bare.roi = None
        return cls(bare, tuple(PackedIndices.of(h.indices) for h in step.handles), _packed(step.fixed),
                   _packed(step.roi))

    @property
    def iterations(self) -> int | None:
        return self.bare.iterations

    @property
    def polish(self) -> int | None:
        return self.bare.polish

    def to_json(self) -> dict:
        """The step as an edit file's step (``Edit.to_json()["steps"]``'s), each index list (``fixed``,
        ``roi``, a handle's ``indices``) in its packed form (:meth:`PackedIndices.to_json`), read back by
        :func:`unpack_step_json`."""
        d = self.bare.step_json()  # (the step without its lists: they are in their packed form here)
        if not self.bare.continues:  # (a continued step's region is the step's before it: not written)
            if self.fixed is not None:
                d["fixed"] = self.fixed.to_json()
            if self.roi is not None:
                d["roi"] = self.roi.to_json()
        for h, p in zip(d.get("handles", ()), self.handles):
            if "indices" in h:  # (a continued step's handles have none)
                h["indices"] = p.to_json()
        return d

    def unpack(self) -> Edit:
        """The step, as it was packed (a new :class:`~hybridedit.fileio.editfile.Edit`, its lists new arrays)."""
        step = copy.copy(self.bare)
        step.handles = [dataclasses.replace(h, indices=p.unpack()) for h, p in zip(self.bare.handles, self.handles)]
        step.fixed, step.roi = _unpacked(self.fixed), _unpacked(self.roi)
        return step


def unpack_step_json(d: dict) -> dict:
    """A step :meth:`PackedStep.to_json` wrote, as an edit file's own step (its index lists as lists of
    ints; anything else as it is, for :func:`~hybridedit.fileio.editfile.parse_edit` to check). A new
    dict; ValueError for a packed list that does not unpack."""
    if not isinstance(d, dict):
        return d
    out = dict(d)
    for key in ("fixed", "roi"):
        if isinstance(out.get(key), dict):
            out[key] = PackedIndices.from_json(out[key]).unpack_checked().tolist()
    if isinstance(out.get("handles"), list):
        out["handles"] = [dict(h, indices=PackedIndices.from_json(h["indices"]).unpack_checked().tolist())
                          if isinstance(h, dict) and isinstance(h.get("indices"), dict) else h
                          for h in out["handles"]]
    return out
