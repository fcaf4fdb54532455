"""The colours the window draws with: the background, the shape, the cage, each vertex role's colour
(its cage points, its tint on the shape, its name in the status bar) and the stretch map's scale.

Tables indexed by role (:mod:`hybridedit.deform.roles`) have the rows FIXED, FREE, then one per handle
group; :func:`role_rows` finds a role's row.
"""

from __future__ import annotations

import numpy as np
from vtkmodules.vtkCommonCore import vtkLookupTable
from vtkmodules.vtkRenderingAnnotation import vtkScalarBarActor

from ...deform.roles import FIRST_HANDLE, FIXED, group, is_handle

BACKGROUND = (0.78, 0.80, 0.84)
"""One colour: a gradient background is a full-window shading pass that cost about 20 ms a frame
with software OpenGL (benchmarks/window_fps.py, creature: overhead 1.30 -> 1.08)."""
SHAPE_COLOR = np.array([226, 210, 184], dtype=np.float64)
CAGE_COLOR = (0.0, 0.55, 0.62)
ROLE_COLORS = np.array([
    [40, 95, 220],   # FIXED: blue
    [60, 190, 70],   # FREE (in the ROI): green
    [255, 115, 20],  # handle group 1: orange
    [225, 40, 160],  # handle group 2: magenta
    [0, 190, 210],   # handle group 3: cyan
    [240, 200, 0],   # handle group 4: yellow
    [150, 70, 230],  # handle group 5: violet
    [150, 90, 40],   # handle group 6: brown
], dtype=np.uint8)
"""Cage point colour per role: FIXED, FREE, then one per handle group (repeating after the last);
rows by :func:`role_rows`."""
ROLE_COLOR_NAMES = ("blue", "green", "orange", "magenta", "cyan", "yellow", "violet", "brown")
"""The name of each colour of :data:`ROLE_COLORS`, in its rows."""


def role_rows(roles, rows: int = len(ROLE_COLORS)):
    """Row of a per-role table for each role (:mod:`hybridedit.deform.roles`): a table's rows are
    FIXED, FREE, then one per handle group, and handle groups past its last row take its handle rows
    again (cyclically).

    Parameters
    ----------
    roles : an int role or an (r,) int array of roles.
    rows : how many rows the table has (default: :data:`ROLE_COLORS`'s).

    Returns
    -------
    The row of each role: an int, or (r,) int64.

    Examples
    --------
    >>> role_rows(np.array([-1, 0, 1, 7])).tolist()  # FIXED, FREE, handle groups 0 and 6
    [0, 1, 2, 2]
    """
    r = np.asarray(roles, dtype=np.int64)
    first = FIRST_HANDLE - FIXED  # the first handle group's row
    out = np.where(is_handle(r), first + group(r) % (rows - first), r - FIXED)
    return int(out) if out.ndim == 0 else out


FIXED_TINT = (np.array([70, 110, 200], dtype=np.float64), 0.45)
HANDLE_TINT = 0.65
"""Colour and strength of the tint of the shape's fixed vertices, and the strength of the handle
groups' tint (in their point colour); free vertices keep the shape colour."""


def shape_tint(roles: np.ndarray) -> np.ndarray:
    """Per shape vertex RGB for its role: FIXED a blue tint, FREE the shape colour, a handle
    group's its colour (orange, magenta, cyan, ...).

    Parameters
    ----------
    roles : (n,) int roles (:mod:`hybridedit.deform.roles`).

    Returns
    -------
    (n, 3) uint8 colours.
    """
    r = np.asarray(roles)
    rgb = np.empty((len(r), 3))
    rgb[:] = SHAPE_COLOR
    colour, w = FIXED_TINT
    rgb[r == FIXED] = (1.0 - w) * SHAPE_COLOR + w * colour
    h = is_handle(r)
    group_colour = ROLE_COLORS[role_rows(r[h])].astype(np.float64)
    rgb[h] = (1.0 - HANDLE_TINT) * SHAPE_COLOR + HANDLE_TINT * group_colour
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


POINT_ALPHA = np.array([[170, 30], [255, 70], [255, 70]], dtype=np.uint8)
"""Cage point opacity (rows FIXED, FREE, any handle group: :func:`role_rows`), facing / facing away
from the camera."""
STRETCH_MAX = 20.0
"""Top of the stretch map's colour scale, in percent of relative edge-length change (clipped above)."""


def stretch_lookup_table(top: float = STRETCH_MAX) -> vtkLookupTable:
    """Blue (no stretch) through green and yellow to red (``top`` percent or more)."""
    lut = vtkLookupTable()
    lut.SetNumberOfTableValues(256)
    lut.SetHueRange(0.66, 0.0)
    lut.SetSaturationRange(0.85, 0.85)
    lut.SetValueRange(0.95, 0.95)
    lut.SetTableRange(0.0, top)
    lut.Build()
    return lut


def stretch_colour_bar(lut: vtkLookupTable) -> vtkScalarBarActor:
    """The stretch map's colour bar for ``lut`` (hidden, at the right of the view; the scene shows it with
    the map)."""
    bar = vtkScalarBarActor()
    bar.SetLookupTable(lut)
    bar.SetTitle("stretch %")
    bar.SetNumberOfLabels(5)
    bar.SetLabelFormat("%.0f")
    # text at fixed sizes (VTK would scale the title to the bar's width: unreadable, and the labels up)
    bar.UnconstrainedFontSizeOn()
    bar.SetVerticalTitleSeparation(10)
    bar.SetTextPad(4)
    bar.SetBarRatio(0.35)
    bar.SetMaximumWidthInPixels(80)
    bar.SetMaximumHeightInPixels(320)
    bar.SetPosition(0.9, 0.08)
    bar.SetWidth(0.08)
    bar.SetHeight(0.45)
    for tp, size in ((bar.GetTitleTextProperty(), 15), (bar.GetLabelTextProperty(), 13)):
        tp.SetColor(0.1, 0.1, 0.12)
        tp.SetShadow(False)
        tp.SetItalic(False)
        tp.SetBold(False)
        tp.SetFontSize(size)
    bar.SetVisibility(False)
    bar.SetPickable(False)
    return bar
