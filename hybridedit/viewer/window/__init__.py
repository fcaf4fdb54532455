"""The main window and its collaborators.

:class:`~.main_window.MainWindow` is a QMainWindow that makes its collaborators and wires them; each
collaborator has one job and takes the window as the narrow protocol its module declares.

Modules
-------
main_window   : the main window: its collaborators made and wired, and its close
actions       : the window's actions, menus and toolbar, and which are enabled
status_bar    : the status bar, the message log, error boxes and questions
status_widgets: the status bar's widgets: the two-line message, fixed-size fields, the row that fits them
slot_errors   : a slot's unexpected error shown in a message box, not as a traceback
interfaces    : the small interfaces several collaborators see one another through
unsaved_mark  : the unsaved-pose mark and the title
file_actions  : open, save, edit files, screenshots, the unsaved-pose question
autosave      : the unsaved pose kept in a recovery file, and offered back after an unclean exit
file_drops    : files dropped on the window
dialogs       : the dialogs: shortcuts, how to edit, about, mesh info
help_texts    : the help texts (How to Edit's is how_to_edit.md, shipped with the package)
first_steps   : the first-steps hint on the view, until the first selection or for good once dismissed
cage_size_box : the toolbar's cage size box (% or vertex count)
shape_loading : opening a shape, rebuilding the cage, the preview while building, installing a build
selecting     : the selection target, selection gestures, the Select menu, mirror, handle groups
posing        : the guard before any change, what follows a drag, polish on release and its result
limb_posing   : the Pose tool: the limb under the mouse, its joint, bent by a drag
undo_commands : undo, redo, reset pose
pose_panel    : Pose ▸ Keep Pose and the Poses panel: kept poses to continue from, rename, remove, export
view_options  : mode, tool, brush, what is drawn (cage, stretch map, look, anti-aliasing), camera, up axis
scene_sync    : the scene kept in step with the session; edge error and stretch map
"""
