"""The help texts: how to edit, the first-steps hint, about, and the mouse bindings (Help > Shortcuts lists them)."""

from __future__ import annotations

from importlib import resources

MOUSE_HELP = [
    ("Left drag", "Camera mode: rotate the view; Select mode: rectangle or brush (the surface it is drawn over, "
                  "through its thickness, not another part behind it or beside it on screen; Select Through, "
                  "Alt+Z, takes everything under it); Drag mode: move the handle in the view plane; Pose mode: "
                  "turn the limb under the cursor about its joint"),
    ("Shift + left drag (Pose mode)", "move the limb in the view plane instead of turning it"),
    ("Wheel over a limb (Pose mode)", "move its joint along it (as [ and ])"),
    ("Left click", "Select mode, rectangle tool: take the nearest cage point (Shift adds, Ctrl removes); "
                   "a click on empty space changes nothing"),
    ("Shift + left drag", "Select mode: add to the selection (Camera mode: pan)"),
    ("Ctrl + left drag", "Select mode: remove from the selection (Camera mode: spin)"),
    ("Alt + left drag", "rotate the view in any mode"),
    ("Left drag on the gizmo", "arrows move the handle along X/Y/Z, rings rotate it (Camera and Drag modes)"),
    ("Middle drag", "pan"),
    ("Right drag / wheel", "zoom"),
    ("Drop a file", "open a mesh (.obj .ply .stl .off) or load an edit (.json)"),
    ("Double-click a kept pose", "Poses panel (Pose ▸ Keep Pose, K): go on editing from it; F2 or a click on the "
                                 "chosen name renames it, Delete removes it"),
]


HOWTO_FILE = "how_to_edit.md"
"""Help ▸ How to Edit's text (Markdown), shipped with the package; docs/window.md holds the same text
between ``how-to-edit`` markers, and a test keeps the two equal."""

HOWTO = resources.files(__package__).joinpath(HOWTO_FILE).read_text(encoding="utf-8")
"""Help ▸ How to Edit: the editing workflow in a few steps (Markdown)."""

FIRST_STEPS = (
    "<b>First steps</b>"
    "<table cellspacing='0' cellpadding='2'>"
    "<tr><td><b>S</b></td><td>Select mode, then drag over the part that may move (<b>R</b>: the ROI, green)</td></tr>"
    "<tr><td><b>H</b></td><td>then drag over the cage points to pull (the handle, orange)</td></tr>"
    "<tr><td><b>D</b></td><td>Drag mode: drag the handle, and the shape follows</td></tr>"
    "<tr><td><b>P</b></td><td>or Pose mode: drag a limb to bend it at its joint</td></tr>"
    "<tr><td><b>C</b></td><td>Camera mode: left drag turns, the wheel zooms, <b>F</b> frames</td></tr>"
    "</table>"
    "Help ▸ How to Edit tells more; × or Esc: not shown again."
)
"""The first-steps hint on the 3D view (:mod:`.first_steps`): the keys to press first (rich text)."""

ABOUT = """\
hybridedit: interactive as-rigid-as-possible editing of large meshes through a QEM cage
(the hybrid method of Borosán, Howard, Zhang and Nealen, Eurographics 2010).

Pick an ROI (green) and a handle (orange) on the cage, then drag the handle."""
