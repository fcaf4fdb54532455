"""The editing state of the window, with no Qt or VTK: what a second front end would drive.

Modules
-------
session         : the editing state on top of the engine: pose, drags and settle, polish, undo, edit files
selection_masks : the session's selection (held, not inherited): ROI and handle-group masks, strokes, roles
history         : the undo/redo stack of snapshots
crash_reports   : an unexpected error written down (traceback, versions, sizes) in the user cache folder
recovery        : the recovery file of an unsaved pose, found after an unclean exit and replayed exactly
picking         : projection, hit tests and add/remove/replace on cage points
surface_pick    : the cage points a gesture takes: the surface in sight and the part behind it
gizmo           : the handle gizmo's parts, hit test and drag transforms
cage_size       : the rule that fits a cage size (fraction or vertex count) to a shape
building        : a shape's engine built from its file (read, cage, binding, editor), with progress and cancel
look            : what a file says the shape looks like (textures, colours), split at seams to draw
opening         : a shape opened for editing without a window (engine, session, look, up axis)
polishing       : the polish of a released drag's region on the full shape, stoppable
pose_library    : the kept poses of a session
"""
