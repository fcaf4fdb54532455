"""The desktop editor window of hybridedit (Qt + pyvista/VTK).

Only this subpackage imports Qt or VTK; it drives the engine
(:class:`hybridedit.deform.editor.HybridEditor`) through its public API.

Modules
-------
app           : ``main()``, QApplication setup and the off-screen screenshot mode
window        : the main window: the assembly of the mixins below and its helpers; it wires Qt to the session
actions       : the window's actions, menus and toolbar, and which are enabled
statusbar     : the status bar, the message log, error boxes and questions
selecting     : the selection target, selection gestures, the Select menu, mirror, the tearing warning
handlegroups  : new / next handle group and the group's name
posing        : drags, the settle after a release, polish on release and its result
viewsettings  : mode, tool, brush, what is drawn (cage, stretch map, look, anti-aliasing), camera, up axis
refresh       : the scene kept in step with the session; edge error and stretch map
loading       : opening a shape, rebuilding the cage, the preview while building, installing a build
undo          : undo, redo, reset pose, and the unsaved mark in the title
drops         : files dropped on the window
session       : the editing state on top of the engine: pose, drags and settle, polish, undo, edit files
selectionstate: the session's selection: ROI and handle-group masks, strokes, the roles they give
scene         : the pyvista actors (shape, cage wireframe, cage points) and in-place updates
shapeparts    : the shape drawn as one plain-coloured actor per vertex role
palette       : the colours: shape, cage, each role's colour and name, the stretch map's scale
look          : what a file says the shape looks like (textures, colours) and how it is shown
interaction   : mouse handling on the 3D view (rubber band, brush, gizmo, screen-plane drag)
gizmo         : the translate/rotate gizmo actors and its drag math
shutdown      : ending a process that ran Qt or VTK without the interpreter's teardown
picking       : pure projection, hit tests and add/remove/replace logic
history       : the undo/redo stack of snapshots
files         : open, save, edit files, screenshots, dropped files, the unsaved-pose question
dragging      : a drag's frames (frame thread to screen) and the settle after a release
framethread   : the thread that computes a drag's frames beside the render
building      : building the cage and binding in the background: progress, cancel, the result's message
polishing     : scheduling the polish on release in background threads
frames        : where a frame's time goes (engine, normals, VTK update, render, compose)
xvfb          : a private virtual X server for tests and benchmarks
worker        : the QThread that reads a mesh and builds the cage and binding
view          : the 3D widget (VTK rendering into a native window, once per frame, timed) and outline overlays
cagesize      : the toolbar's cage size control (% or vertex count)
statusfield   : the status bar's widgets: the two-line message, fixed-size fields, the row that fits them
help          : help texts and the shortcuts dialog
dialogs       : the information dialogs (shortcuts, how to edit, about, mesh info)
"""
