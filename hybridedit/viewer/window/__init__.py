"""The main window and its parts.

Modules
-------
main_window   : the main window: the assembly of its parts
actions       : the window's actions, menus and toolbar, and which are enabled
status_bar    : the status bar, the message log, error boxes and questions
status_widgets: the status bar's widgets: the two-line message, fixed-size fields, the row that fits them
dialogs       : the dialogs: shortcuts, how to edit, about, mesh info
help_texts    : the help texts
file_actions  : open, save, edit files, screenshots, the unsaved-pose question
file_drops    : files dropped on the window
cage_size_box : the toolbar's cage size box (% or vertex count)
selecting     : the selection target, selection gestures, the Select menu, mirror, the tearing warning
handle_groups : new / next handle group and the group's name
posing        : drags, the settle after a release, polish on release and its result
view_options  : mode, tool, brush, what is drawn (cage, stretch map, look, anti-aliasing), camera, up axis
scene_sync    : the scene kept in step with the session; edge error and stretch map
shape_loading : opening a shape, rebuilding the cage, the preview while building, installing a build
undo_commands : undo, redo, reset pose, and the unsaved mark in the title
"""
