"""The help texts: how to edit, about, and the mouse bindings (Help > Shortcuts lists them)."""

from __future__ import annotations

MOUSE_HELP = [
    ("Left drag", "Camera mode: rotate the view; Select mode: rectangle or brush (the part it is drawn over, "
                  "through its thickness, not what another part hides; Select Through, Alt+Z, takes that too); "
                  "Drag mode: move the handle in the view plane"),
    ("Left click", "Select mode, rectangle tool: take the nearest cage point (Shift adds, Ctrl removes); "
                   "a click on empty space changes nothing"),
    ("Shift + left drag", "Select mode: add to the selection (Camera mode: pan)"),
    ("Ctrl + left drag", "Select mode: remove from the selection (Camera mode: spin)"),
    ("Alt + left drag", "rotate the view in any mode"),
    ("Left drag on the gizmo", "arrows move the handle along X/Y/Z, rings rotate it (Camera and Drag modes)"),
    ("Middle drag", "pan"),
    ("Right drag / wheel", "zoom"),
    ("Drop a file", "open a mesh (.obj .ply .stl .off) or load an edit (.json)"),
]


HOWTO = """\
1. Select mode (S), target ROI (R): drag a rectangle (or use the brush, B) over the cage
   vertices that may move. Shift adds, Ctrl removes, a plain drag replaces. The part you draw
   over is taken through its thickness (an arm drawn over from the front: its back too), not
   a part hidden behind another; Select > Select Through (Alt+Z) takes those too. The status
   bar warns when a handle touches the held part with nothing free between them (a drag
   would tear there). A click takes the nearest cage vertex in sight; a click on empty space
   changes nothing. A rectangle over empty space empties the target (Ctrl+Z restores it).
   Ctrl+Shift+A clears the ROI and every handle group; Alt+A the current target only.
2. Target Handle (H): select the cage vertices you want to pull.
   Cage points: blue = fixed (outside the ROI), green = free (ROI), orange = handle.
3. Drag mode (D): drag with the left button to move the handle parallel to the view;
   or grab the gizmo (arrows move along X/Y/Z, rings rotate, the white ball moves freely).
   On release the pose settles to what 'hybridedit deform' computes; then, with Edit >
   Polish on Release (on by default), full-resolution ARAP of the edited region runs in the
   background until it converges (at most 200 iterations; the status bar reports them and
   the edge error before and after). The polished pose is what you see, what File > Save
   writes and where the next drag starts; Ctrl+Z undoes the polish on its own. File > Save
   Edit (Ctrl+E) writes every step since the rest pose, polishes included: 'hybridedit
   deform' replays them to the pose on screen.
   A new selection starts from the pose on screen: only its region can move, and a part
   posed before stays exactly where it is.
4. Undo / redo with Ctrl+Z / Ctrl+Shift+Z (a selection step never moves the shape);
   Reset Pose (Ctrl+R) returns to rest.
5. File > Save writes the deformed mesh; File > Save Edit writes the selection and the
   handle transform as a JSON edit file. It holds only the last selection and its drag,
   replayed from the rest pose: 'hybridedit deform in.obj -o out.obj --edit edit.json
   --cage N' gives the shape you see (Mirror included) when N is the window's cage size
   and that selection was made on the rest pose, with no polish since.
Navigate: Camera mode (C) rotates with the left button; middle drag pans, the wheel
zooms, Alt + left drag rotates in any mode; F frames the shape, W shows/hides the cage.
T (View > Stretch Map) colours the shape by how much its edges stretched or shrank
against the rest shape (blue 0 % to red 20 % or more). Alt+1 / Alt+2 / Alt+3 (View >
Texture / Colours / Plain) show the file's textures, its vertex colours, or the form
alone (the default is what the file has). File > Mesh Info lists the
counts and any repairs made to the input when it was loaded."""

ABOUT = """\
hybridedit: interactive as-rigid-as-possible editing of large meshes through a QEM cage
(the hybrid method of Borosán, Howard, Zhang and Nealen, Eurographics 2010).

Pick an ROI (green) and a handle (orange) on the cage, then drag the handle."""
