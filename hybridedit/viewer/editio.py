"""The JSON edit file <-> the window's editing state.

The window keeps the handle transform as a 4x4 matrix; the edit file stores a
rotation (axis, degrees, center) followed by a translation.
:func:`hybridedit.transforms.decompose_rigid` converts one into the other.
"""

from __future__ import annotations

import numpy as np

from ..editfile import Edit
from ..editor import HybridEditor
from ..transforms import decompose_rigid


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
