"""The desktop editor window of hybridedit (Qt + pyvista/VTK).

Only this subpackage imports Qt or VTK; it drives the engine
(:class:`hybridedit.deform.editor.HybridEditor`) through its public API.

Modules
-------
app        : ``main()``, QApplication setup and the off-screen screenshot mode
window     : the main window: menus, toolbar, status bar; it wires Qt to the session
session    : the editing state (selection masks, handle transform, undo) on top of the engine
scene      : the pyvista actors (shape, cage wireframe, cage points) and in-place updates
interaction: mouse handling on the 3D view (rubber band, brush, gizmo, screen-plane drag)
gizmo      : the translate/rotate gizmo actors and its drag math
shutdown   : ending a process that ran Qt or VTK without the interpreter's teardown
selection  : pure projection, hit tests and add/remove/replace logic
history    : the undo/redo stack of snapshots
files      : open, save, edit files, screenshots, dropped files, the unsaved-pose question
dragging   : a drag's frames (frame thread to screen) and the settle after a release
building   : building the cage and binding in the background: progress, cancel, the result's message
polishing  : scheduling the polish on release in background threads
regional   : compiled per-frame kernels (points, normals, edge error, stretch) for the moving region
frames     : where a frame's time goes (engine, normals, VTK update, render, compose)
xvfb       : a private virtual X server for tests and benchmarks
worker     : the QThread that reads a mesh and builds the cage and binding
view       : the 3D widget (VTK rendering into a native window, once per frame, timed) and outline overlays
cagesize   : the toolbar's cage size control (% or vertex count)
help       : help texts and the shortcuts dialog
dialogs    : the information dialogs (shortcuts, how to edit, about, mesh info)
"""
