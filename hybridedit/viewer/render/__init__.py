"""Drawing the session: VTK actors through pyvista, and the 3D view widget they render in.

Modules
-------
scene        : the pyvista actors (shape, cage wireframe, cage points, gizmo) and in-place updates
shape_parts  : the shape drawn as one plain-coloured actor per vertex role
palette      : the colours: shape, cage, each role's colour and name, the stretch map's scale
view         : the 3D widget (VTK rendering into a native window, once per frame, timed), outline overlays
gizmo_actors : the handle gizmo's arrows, rings and ball
stage_times  : where a frame's time goes (engine, normals, VTK update, render, compose)
"""
