"""The mouse on the 3D view and the drags it makes.

Modules
-------
mouse_gestures : mouse handling on the view (rubber band, brush, gizmo, screen-plane drag)
drags          : a drag's frames, from the mouse to the screen, and the settle after a release
frame_thread   : the thread that computes a drag's frames beside the render
"""
