"""The JSON edit file <-> the window's editing state.

The window keeps the handle transform as a 4x4 matrix; the edit file stores a
rotation (axis, degrees, center) followed by a translation. :func:`decompose_rigid`
converts one into the other.
"""

from __future__ import annotations

import numpy as np

from ..editfile import Edit
from ..editor import HybridEditor


def decompose_rigid(T: np.ndarray, center: np.ndarray) -> tuple[np.ndarray, dict | None]:
    """Split a rigid transform into a rotation about ``center`` and a translation.

    ``x -> R (x - center) + center + translate`` equals ``T`` (as
    :func:`hybridedit.transforms.rigid_transform` builds it).

    Parameters
    ----------
    T : (4, 4) rigid transform (orthonormal rotation part, det +1).
    center : (3,) the point the rotation is about.

    Returns
    -------
    translate : (3,) float64
    rotate : None for no rotation, else {"axis": (3,), "degrees": float, "center": (3,)}

    Raises
    ------
    ValueError
        When ``T`` is not a rigid transform.
    """
    T = np.asarray(T, dtype=np.float64)
    R = T[:3, :3]
    if not np.all(np.isfinite(T)) or not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise ValueError("the handle transform is not a rotation plus a translation")
    c = np.asarray(center, dtype=np.float64).reshape(3)
    cos = np.clip((np.trace(R) - 1.0) * 0.5, -1.0, 1.0)
    angle = float(np.arccos(cos))
    if angle < 1e-12:
        return T[:3, 3].copy(), None
    if angle < np.pi - 1e-6:
        axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        axis /= 2.0 * np.sin(angle)
    else:  # near a half turn: R + I = 2 a a^T
        S = (R + np.eye(3)) * 0.5
        k = int(np.argmax(np.diag(S)))
        axis = S[:, k] / np.sqrt(max(S[k, k], 1e-300))
    axis /= np.linalg.norm(axis)
    translate = T[:3, 3] - (c - R @ c)
    return translate, {"axis": axis, "degrees": float(np.degrees(angle)), "center": c}


def make_edit(roi: np.ndarray, handle: np.ndarray, T: np.ndarray, center: np.ndarray) -> Edit:
    """An :class:`Edit` in cage space from the window's masks and handle transform.

    Parameters
    ----------
    roi, handle : (c,) bool masks over the cage vertices.
    T : (4, 4) handle transform since the selection was applied.
    center : (3,) handle centroid when the selection was applied (the rotation center).
    """
    translate, rotate = decompose_rigid(T, center)
    return Edit(
        handle=np.flatnonzero(handle).astype(np.int64),
        roi=np.flatnonzero(roi).astype(np.int64),
        space="cage",
        translate=translate,
        rotate=rotate,
    )


def edit_to_masks(editor: HybridEditor, edit: Edit) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Map an edit's selection onto the cage and build its transform as ``hybridedit deform`` does.

    Returns
    -------
    roi, handle : (c,) bool masks over the cage vertices.
    T : (4, 4) handle transform (rotation about ``rotate.center``, by default the
        centroid of the edit's handle vertices at rest, in the edit's space).

    Raises
    ------
    hybridedit.editor.SelectionError
        For indices out of range or an empty handle.
    """
    c = editor.cage.n_vertices
    h_idx = editor.to_cage(edit.handle, edit.space, "handle")
    handle = np.zeros(c, dtype=bool)
    handle[h_idx] = True
    roi = np.zeros(c, dtype=bool)
    if edit.roi is not None:
        roi[editor.to_cage(edit.roi, edit.space, "roi")] = True
    elif edit.fixed is not None:
        roi[:] = True
        roi[editor.to_cage(edit.fixed, edit.space, "fixed")] = False
    else:
        roi[:] = True  # nothing fixed
    roi |= handle
    pts = editor.mesh.vertices if edit.space == "shape" else editor.cage.vertices
    T = edit.transform(default_center=pts[edit.handle].mean(axis=0))
    return roi, handle, T
