"""A drag's transform arguments (``translate``, ``rotate``, ``transform``, ``transforms``) as each
handle group's (4, 4) matrix: what :meth:`hybridedit.HybridEditor.drag` and
:meth:`~hybridedit.HybridEditor.pose` take, checked and turned into transforms."""

from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.transforms import check_transform, rigid_transform
from .selection import SelectionError

__all__ = ["group_transform", "requested_transforms"]

_ROTATE_FORMS = "rotate must be a 3x3 rotation matrix, a scipy Rotation or {\"axis\": ..., \"degrees\": ..., \"center\": ...}"


def _rotation_matrix(rotate) -> np.ndarray:
    """A (3, 3) proper rotation from a matrix or a scipy ``Rotation`` (ValueError for anything else)."""
    R = rotate.as_matrix() if isinstance(rotate, Rotation) else np.asarray(rotate, dtype=np.float64)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) \
            or np.linalg.det(R) < 0:
        raise ValueError(_ROTATE_FORMS)
    return R


def _rotation_about(rotate, center: np.ndarray) -> np.ndarray:
    """The (4, 4) of ``rotate`` (a matrix, a ``Rotation`` or {"axis", "degrees", "center"}) about
    ``center``, or about the centre the dict gives."""
    if isinstance(rotate, dict):
        c = rotate.get("center")
        return rigid_transform(axis=rotate.get("axis"), degrees=float(rotate.get("degrees", 0.0)),
                               center=center if c is None else c)
    R = _rotation_matrix(rotate)
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = center - R @ center
    return T


def group_transform(translate, rotate, transform, *, center: np.ndarray) -> np.ndarray:
    """One handle group's (4, 4) transform from :meth:`~hybridedit.HybridEditor.drag`'s arguments.

    Parameters
    ----------
    translate : (3,) translation, or None.
    rotate : None, a (3, 3) rotation matrix, a scipy ``Rotation`` or
        ``{"axis": (3,), "degrees": a, "center": (3,)}``; applied before ``translate``.
    transform : (4, 4) affine transform, or None (then neither of the above may be given).
    center : (3,) the point a rotation without a centre turns about (the group's default centre).

    Returns
    -------
    (4, 4) float64 array.

    Raises
    ------
    ValueError
        ``transform`` given with ``translate`` or ``rotate``, or a malformed argument.
    """
    if transform is not None:
        if translate is not None or rotate is not None:
            raise ValueError("give transform, or translate and/or rotate, not both")
        return check_transform(transform)
    T = np.eye(4) if rotate is None else _rotation_about(rotate, center)
    if translate is not None:
        T = rigid_transform(translate=translate) @ T
    return T


def _check_group(g, n_groups: int) -> int:
    """``g`` as a handle group index of a selection of ``n_groups`` (SelectionError when it is none)."""
    if not isinstance(g, (int, np.integer)) or not (0 <= int(g) < n_groups):
        raise SelectionError(f"no handle group {g!r}; the selection has {n_groups}")
    return int(g)


def requested_transforms(current: Sequence[np.ndarray], centers: Sequence[np.ndarray], *, translate, rotate,
                         transform, group, transforms) -> list[np.ndarray]:
    """Every handle group's (4, 4) transform after a :meth:`~hybridedit.HybridEditor.drag` with
    these arguments: ``transforms`` ({group: (4, 4)}) sets several groups, else ``translate`` /
    ``rotate`` / ``transform`` set group ``group``; the others keep their ``current`` transforms.

    Parameters
    ----------
    current : the current transform of each handle group (its length is the number of groups).
    centers : the default rotation centre of each handle group.

    Raises
    ------
    SelectionError
        A group the selection does not have.
    ValueError
        Both ``transforms`` and one group's arguments, or a malformed transform.
    """
    n_groups = len(current)
    new = list(current)
    if transforms is not None:
        if translate is not None or rotate is not None or transform is not None:
            raise ValueError("give transforms, or one group's translate/rotate/transform, not both")
        for g, T in dict(transforms).items():
            new[_check_group(g, n_groups)] = check_transform(T)
    else:
        g = _check_group(group, n_groups)
        new[g] = group_transform(translate, rotate, transform, center=centers[g])
    return new
