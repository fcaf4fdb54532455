"""``hybridedit web``: the editor in a browser, served by trame on the same Qt-free model as the window.

The server holds a :class:`~hybridedit.viewer.model.session.Session` and draws its
:class:`~hybridedit.viewer.render.scene.Scene` on an off-screen pyvista plotter; the
browser shows the rendered images (:mod:`.editor_app`) and sends its mouse and keys back.
Only a browser that knows the token printed at start may connect (:mod:`.token_guard`).
"""
