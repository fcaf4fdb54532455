"""The desktop editor window of hybridedit (Qt + pyvista/VTK).

Only this subpackage imports Qt or VTK; it drives the engine
(:class:`hybridedit.deform.editor.HybridEditor`) through its public API. Its parts, by concern
(each sub-package imports only those before it):

model   : the editing state, with no Qt or VTK: session, selection masks, undo history, picking and
          gizmo math, the cage size rule (what another front end, a notebook or a browser, would drive)
render  : drawing it: the scene's actors, the shape's parts, colours, a file's look, the 3D view, the
          gizmo's actors, where a frame's time goes
input   : the mouse on the 3D view, a drag's frames and their thread
jobs    : the background threads: cage and binding builds, polish on release, and their schedulers
window  : the main window and its parts: actions, status bar, dialogs, files, and the commands

Modules here: ``app`` (``main()``, the off-screen screenshot mode) and ``shutdown`` (ending a
process that ran Qt or VTK without the interpreter's teardown; plain Python).
"""
