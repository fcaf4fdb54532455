"""A closed step of a pose record kept small: its vertex index lists packed (:class:`PackedStep`).

The record of how a pose was made keeps every step since the rest pose (:mod:`~hybridedit.deform.pose_record`),
so a long session keeps thousands: as int64 lists, a selection of a fifth of the creature (100K
vertices) is 295 KB a step (290 MB in 1,000 steps). A sorted list of distinct indices is kept as a
bit mask over ``[0, last]``, compressed (a region is a few runs of a mesh's vertex order: 3 KB a
step there); any other list as it is. Unpacking gives the lists back exactly.
"""

from __future__ import annotations

import copy
import dataclasses
import zlib
from dataclasses import dataclass

import numpy as np

from ..fileio.editfile import Edit

__all__ = ["PackedIndices", "PackedStep"]

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

    def unpack(self) -> Edit:
        """The step, as it was packed (a new :class:`~hybridedit.fileio.editfile.Edit`, its lists new arrays)."""
        step = copy.copy(self.bare)
        step.handles = [dataclasses.replace(h, indices=p.unpack()) for h, p in zip(self.bare.handles, self.handles)]
        step.fixed, step.roi = _unpacked(self.fixed), _unpacked(self.roi)
        return step
