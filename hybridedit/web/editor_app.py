"""The trame application of ``hybridedit web``: a session and its scene, shown in the browser.

The scene is drawn on the server (an off-screen pyvista plotter, EGL when there is no
display) and sent to the page as images (trame-vtk's ``VtkRemoteView``); the page's
mouse events arrive at the plotter's VTK interactor, where :class:`~.gestures.Gestures`
turns them into session calls, and its keys at the ``hotkey`` trigger (:mod:`.keys`).
While Select or Drag is on the interactor's style is a do-nothing one (the camera
stays); in Camera mode it is the usual trackball.
"""

from __future__ import annotations

import asyncio
import functools
import os
import sys
import tempfile
from pathlib import Path

from ..core.mesh import Mesh
from ..defaults import CAGE_SIZE
from ..fileio.editfile import save_edit
from ..fileio.meshfiles import write_mesh
from ..deform.selection import SelectionError
from .gestures import BRUSH, BRUSH_PIXELS, CAMERA, DRAG, HANDLE, POSE, RECTANGLE, ROI, SELECT, Gestures
from .keys import action_of
from .opening_job import OpeningJob
from .page import build_page
from .polish_on_release import PolishOnRelease
from .server_files import posed_name
from .token_guard import token_middleware

VIEW_EVENTS = ("LeftButtonPressEvent", "MouseMoveEvent", "LeftButtonReleaseEvent")


def _editing(method):
    """A page action that needs the shape built: nothing happens before (the build's progress is shown)."""
    @functools.wraps(method)
    def guarded(self, *args, **kwargs):
        if self.session is None:
            return None
        return method(self, *args, **kwargs)
    return guarded


def edit_path_of(mesh_path: Path) -> Path:
    """Where Save Edit writes: beside the mesh, ``<stem>-edit.json`` (the window's suggested name)."""
    return mesh_path.with_name(mesh_path.stem + "-edit.json")


class WebEditor:
    """One session served to the browser.

    Parameters
    ----------
    session : the session edited (:func:`~hybridedit.viewer.model.opening.open_session`), or None: the
        page shows the build of :meth:`open_file` until :meth:`attach` gives it one.
    token : the token a browser must show (:mod:`.token_guard`).
    up_axis : the shape's up axis (the camera's up).
    server : a trame server (default: a new one).
    guard_pages : answer HTTP requests without the token 403 (:mod:`.token_guard`); off where the
        page is framed by another site's page (a notebook's), which sends it no cookie: the session
        (the websocket) still opens only with the token.
    name : the shape's file name, for the page's title (default: the session's).
    """

    def __init__(self, session, token: str, up_axis: str = "+Y", server=None, *, guard_pages: bool = True,
                 name: str | None = None) -> None:
        import pyvista as pv
        from trame.app import get_server
        from vtkmodules.vtkInteractionStyle import vtkInteractorStyleUser

        from ..viewer.app import _headless_render_window
        from ..viewer.render.depth_grab import DepthGrab
        from ..viewer.render.scene import Scene

        self.session = None
        self.name = name or (session.path.name if session is not None and session.path else "shape")
        self.gestures: Gestures | None = None
        self.polisher: PolishOnRelease | None = None
        self.opening: OpeningJob | None = None
        self.token = token
        self.guard_pages = guard_pages
        self.server = server or get_server(name=f"hybridedit-{id(self)}", client_type="vue3")
        self.server.client_type = "vue3"
        self.server.cli.set_defaults(authKey=token)
        self.state, self.ctrl = self.server.state, self.server.controller
        _headless_render_window()
        self.plotter = pv.Plotter(off_screen=True, window_size=[1000, 800])
        self.scene = Scene(self.plotter)
        self.scene.up_axis = up_axis
        self.depth = DepthGrab(self.plotter.ren_win, self.scene.renderer)
        self._pushed = 0  # counts the poses and selections pushed: with the camera, the depth's key
        self._frame_waiting = False  # a drag frame is waiting to be drawn
        camera = self.scene.renderer.GetActiveCamera()
        self.depth.key_fn = lambda: (camera.GetMTime(), tuple(self.plotter.ren_win.GetSize()), self._pushed)
        self.iren = self.plotter.iren.interactor
        self._turn_style = self.iren.GetInteractorStyle()
        self._still_style = vtkInteractorStyleUser()  # does nothing: the camera stays while selecting or dragging
        for event in VIEW_EVENTS:
            self.iren.AddObserver(event, self._on_mouse, 1.0)
        self.saved_edit: Path | None = None
        self.state.update({"building": session is None, "build_stage": "", "build_percent": 0,
                           "build_failed": "", "status": "", "brush_px": BRUSH_PIXELS})
        build_page(self)
        self.server.trigger("hotkey")(self.on_hotkey)
        self.server.trigger("download_mesh")(self.download_mesh)
        self.server.trigger("hover")(self.on_hover)
        self.ctrl.on_server_bind.add(self._on_bind)
        self.ctrl.on_client_connected.add(self._on_connect)
        self.state.change("mode")(lambda mode, **_: self.set_mode(mode))
        self.state.change("target")(lambda target, **_: self.set_target(target))
        self.state.change("tool")(lambda tool, **_: self.set_tool(tool))
        if session is not None:
            self.attach(session)

    def attach(self, session, up_axis: str | None = None) -> None:
        """Edit ``session`` from now on (a built shape): drawn, and the page's tools working on it."""
        from ..viewer.render.gl_renderer import choose_antialiasing

        self.session = s = session
        if up_axis is not None:
            self.scene.up_axis = up_axis
        self.scene.load(s.metrics, s.shown_positions, s.cage_positions, s.editor.cage.faces,
                        s.selection.cage_roles(), s.selection.shape_roles(), look=s.look)
        s.look_mode = self.scene.look_mode
        self.scene.reset_camera()
        self.plotter.ren_win.Render()
        choose_antialiasing(self.plotter.ren_win)  # (off for software OpenGL: half the frame)
        self.gestures = Gestures(s, self.scene, self.depth)
        self.polisher = PolishOnRelease(s, self._polished)
        with self.state:
            if s.path is not None and not self.state.save_name:
                self.state.save_name = posed_name(s.path)
            self.state.building = False
            self.state.build_failed = ""
        self.set_mode(CAMERA)
        self.set_target(ROI)
        self.show_status()

    # ------------------------------------------------------------------ opening a file
    def open_file(self, path: Path, *, mesh=None, look=None, cage_size: int | float = CAGE_SIZE, edit=None,
                  edit_path: str | None = None) -> None:
        """Build the shape of ``path`` (``mesh``: as read already, with its ``look``) in the background, the
        page showing the shape as soon as it is read and the build's progress over it, with Cancel; then
        edit it (``edit``, an :class:`~hybridedit.Edit`, replayed first). Called on the server's loop."""
        from ..viewer.model.building import BuildRequest

        self._opening_args = dict(mesh=mesh, look=look, cage_size=cage_size, edit=edit, edit_path=edit_path)
        self._path = Path(path)
        with self.state:
            self.state.building = True
            self.state.build_failed = ""
            self.state.build_stage, self.state.build_percent = f"reading {self._path.name}", 0
        request = BuildRequest(cage_size=cage_size, path=self._path, mesh=mesh)
        self.opening = OpeningJob(request, look=look, progress=self._build_progress, shape_read=self._shape_read,
                                  finished=self._built)
        self.opening.start()

    def open_again(self) -> None:
        """The page's Open Again, after a cancelled or failed build."""
        if self.session is None and (self.opening is None or not self.opening.running):
            self.open_file(self._path, **self._opening_args)

    def cancel_build(self) -> None:
        """The page's Cancel: the build stops at its next step."""
        if self.opening is not None:
            self.opening.cancel()

    def _build_progress(self, stage: str, fraction: float) -> None:
        with self.state:
            self.state.build_stage = stage
            self.state.build_percent = round(100 * min(max(fraction, 0.0), 1.0))
            self.state.status = f"{self._path.name}: {stage} {self.state.build_percent}%"

    def _shape_read(self, mesh, _look, up) -> None:
        """The shape is read: shown (plain) while its cage and binding are built."""
        self.scene.up_axis = up[0]
        self.scene.show_preview(mesh.vertices, mesh.faces)
        self.scene.reset_camera()
        self._pushed += 1
        self.view.update()

    def _built(self, result, message: str) -> None:
        """The build ended: its result installed (after the page is told), or why not said."""
        if result is None:
            said = "The build was cancelled" if message == "cancelled" else f"Could not open {self._path.name}: {message}"
            print(f"hybridedit: {said}", file=sys.stderr, flush=True)
            with self.state:
                self.state.build_failed = said
                self.state.status = said
            return
        with self.state:  # (said before the shape is drawn, which takes a while on a big one: a minute at 11M)
            self.state.build_stage = f"drawing {result.mesh.n_vertices:,} vertices"
            self.state.build_percent = 100
        asyncio.get_running_loop().call_later(0.1, self._install, result)

    def _install(self, result) -> None:
        """A finished build becomes the session edited: the edit replayed, the shape drawn."""
        from ..viewer.model.session import Session

        args = self._opening_args
        session = Session(result.editor, path=self._path, cage_size=args["cage_size"], metrics=result.metrics)
        session.look = result.look
        for note in session.look.notes if session.look is not None else ():
            print(f"hybridedit: note: {self._path.name}: {note}", file=sys.stderr, flush=True)
        problem = ""
        if args["edit"] is not None:
            try:
                session.load_edit(args["edit"], args["edit_path"])
            except (SelectionError, ValueError) as e:
                problem = f"the edit {args['edit_path']} was not replayed: {e}"
                print(f"hybridedit: {problem}", file=sys.stderr, flush=True)
        print(f"hybridedit: {self._path.name} ready ({result.seconds:.1f} s)", flush=True)
        self.attach(session, result.up[0] if result.up else None)
        if problem:
            self.gestures.message = problem[0].upper() + problem[1:]
            self.show_status()
        self.push()

    # ------------------------------------------------------------------ the page
    @_editing
    def show_status(self) -> None:
        """The status line: vertices, cage size, edge error, and the latest message."""
        s = self.session
        sel = s.selection
        text = (f"{s.mesh.n_vertices:,} vertices, cage {s.n_cage:,}; edge error {s.rrms_error():.2f}%;"
                f" ROI {int(sel.roi.sum())}, handle {int(sel.handle.sum())} cage points;"
                f" {self.gestures.mode}, target {self.gestures.target}")
        if self.gestures.mode == SELECT:
            text += f", {self.gestures.tool}"
            if self.gestures.tool == BRUSH:
                text += f" {self.gestures.brush_radius:.0f} px"
        if sel.n_groups > 1:
            text += f"; {self._group_words()}"
        if sel.symmetry is not None:
            text += f"; mirror {sel.symmetry.upper()}"
        if self.gestures.select_through:
            text += "; select through"
        if self.gestures.frame_ms is not None:
            text += f"; frame {self.gestures.frame_ms:.1f} ms"
        if self.polisher.running:
            text += " -- polishing..."
        elif self.gestures.message:
            text += f" -- {self.gestures.message}"
        with self.state:
            self.state.status = text

    @_editing
    def push(self) -> None:
        """Draw the session's state again (the whole shape, the cage, the roles) and send the image."""
        s = self.session
        self.scene.update_shape(s.shown_positions, everything=True)
        self._stretch(s.shown_positions, everything=True)
        self.scene.update_cage(s.cage_positions)
        self.scene.update_roles(s.selection.cage_roles(), s.selection.shape_roles())
        self.scene.gizmo.place(s.handle_centroid() if self.gestures.mode == DRAG else None)
        self._pushed += 1
        self.view.update()

    def _stretch(self, V, *, everything: bool) -> None:
        """The stretch map of the pose V, when it is shown (the moving region only, unless ``everything``)."""
        if self.scene.stretch_visible:
            self.session.metrics.update_error(V, everything=everything)
            self.session.metrics.write_stretch(self.scene.stretch32, everything=everything)
            self.scene.stretch_modified()

    def _frame_due(self) -> None:
        """A drag moved the shape: draw it once the events waiting now have been handled (mouse moves
        come faster than frames are drawn; each is solved, the latest is drawn)."""
        if self._frame_waiting:
            return
        self._frame_waiting = True
        try:
            asyncio.get_running_loop().call_soon(self._push_frame)
        except RuntimeError:  # (no event loop: at once)
            self._push_frame()

    @_editing
    def _push_frame(self) -> None:
        """A drag frame (the moving region of the shape and the cage) or a brush stroke's selection so far.
        While the mouse is down the view streams images of its own (trame-vtk's interaction animation),
        so this one only asks."""
        self._frame_waiting = False
        if not self.gestures.busy:
            return  # (released since: the release drew everything)
        s = self.session
        if self.gestures.mode == SELECT:
            self.scene.update_roles(s.selection.cage_roles(), s.selection.shape_roles())
            self._pushed += 1
            self.view.update()
            return
        self.scene.update_shape(s.shape_positions)
        self._stretch(s.shape_positions, everything=False)
        self.scene.update_cage(s.cage_positions)
        self.scene.gizmo.place(s.handle_centroid())
        self._pushed += 1
        self.view.update()

    # ------------------------------------------------------------------ modes and keys
    @_editing
    def set_mode(self, mode: str) -> None:
        """CAMERA (the mouse turns the camera), SELECT, DRAG or POSE."""
        if mode not in (CAMERA, SELECT, DRAG, POSE) or self.gestures.busy:
            return
        self.gestures.mode = mode
        if self.gestures.shown_limb is not None:
            self.gestures.shown_limb = None
            self.scene.pivot.place(None)
        self._want_depth()
        self.iren.SetInteractorStyle(self._turn_style if mode == CAMERA else self._still_style)
        if self.state.mode != mode:
            self.state.mode = mode
        self.show_status()
        self.push()

    def _want_depth(self) -> None:
        """The depth buffer is read at each render that moved something: only where a press needs it (a
        selection, the limb under the mouse), and not during a drag's frames."""
        g = self.gestures
        self.depth.wanted = g.mode == SELECT or (g.mode == POSE and not g.busy)

    @_editing
    def set_target(self, target: str) -> None:
        """What a selection takes into: ROI or HANDLE."""
        if target not in (ROI, HANDLE):
            return
        self.gestures.target = target
        if self.state.target != target:
            self.state.target = target
        self.show_status()

    @_editing
    def set_tool(self, tool: str) -> None:
        """How a selection is drawn: RECTANGLE or BRUSH."""
        if tool not in (RECTANGLE, BRUSH) or self.gestures.busy:
            return
        self.gestures.tool = tool
        if self.state.tool != tool:
            self.state.tool = tool
        self.show_status()

    @_editing
    def on_hotkey(self, key: str, ctrl: bool = False, shift: bool = False, alt: bool = False) -> None:
        """A key press on the page (:data:`.keys.KEY_SCRIPT`)."""
        action = action_of(key, bool(ctrl), bool(shift), bool(alt))
        simple = {"undo": self.undo, "redo": self.redo, "stretch": self.toggle_stretch,
                  "mirror_x": self.toggle_mirror, "free_around_handle": self.free_around_handles,
                  "reset_camera": self.reset_camera, "new_group": self.new_group, "next_group": self.next_group,
                  "select_through": self.toggle_select_through,
                  "brush_bigger": lambda: self._bracket(+1), "brush_smaller": lambda: self._bracket(-1)}
        if action in simple:
            simple[action]()
        elif action in ("mode_select", "mode_drag", "mode_camera", "mode_pose"):
            self.set_mode(action.removeprefix("mode_"))
        elif action in ("target_roi", "target_handle"):
            self.set_target(ROI if action == "target_roi" else HANDLE)
        elif action in ("tool_rect", "tool_brush"):
            self.set_tool(RECTANGLE if action == "tool_rect" else BRUSH)

    # ------------------------------------------------------------------ actions
    @_editing
    def undo(self) -> None:
        if self.gestures.busy:
            return
        self.polisher.cancel()
        if self.session.undo():
            self._changed()

    @_editing
    def redo(self) -> None:
        if self.gestures.busy:
            return
        self.polisher.cancel()
        if self.session.redo():
            self._changed()

    @_editing
    def toggle_mirror(self, axis: str = "x") -> None:
        """Mirror X (Shift+X): the selection and the drag mirrored across the shape's middle plane, or not."""
        s = self.session
        if self.gestures.busy:
            return
        self.polisher.cancel()
        on = s.selection.symmetry != axis
        try:
            s.set_mirror(axis if on else None)
        except SelectionError as e:
            self.gestures.message = f"Cannot mirror across {axis.upper()}: {e}"
        else:
            self.gestures.message = (f"Mirror {axis.upper()}: the selection and the drag are mirrored across the "
                                     "shape's middle plane" if on else "Mirror off")
        self._changed()

    @_editing
    def free_around_handles(self) -> None:
        """Free Around Handle (Shift+F): the held cage points a handle touches join the ROI (one undo step)."""
        if self.gestures.busy:
            return
        self.polisher.cancel()
        sel = self.session.selection
        n = sel.free_around_handles()
        if n == 0:
            self.gestures.message = "No handle touches the held part: nothing to free"
        else:
            self.gestures.message = sel.tearing_warning() or (
                f"Freed {n} held cage point{'s' if n != 1 else ''} around the handle: they join the ROI"
                " (Ctrl+Z restores them)")
        self._changed()

    def _bracket(self, sign: int) -> None:
        """``]`` (+1) and ``[`` (-1): in Pose mode over a limb its joint moves, else the brush's size changes
        (the window's two uses of the keys)."""
        if self.gestures.mode == POSE and self.gestures.move_joint(sign):
            self.show_status()
            self._pushed += 1
            self.view.update()
            return
        self.scale_brush(1.25 if sign > 0 else 0.8)

    @_editing
    def on_hover(self, x: float, y: float) -> None:
        """The page's pointer over the view with no button down (:data:`.pose_hover.HOVER_SCRIPT`)."""
        if self.gestures.hover(float(x), float(y)):
            self._pushed += 1
            self.view.update()

    @_editing
    def scale_brush(self, factor: float) -> None:
        """``]`` and ``[``: the brush's radius times ``factor`` (the ring the page draws follows)."""
        self.gestures.scale_brush(factor)
        self.state.brush_px = self.gestures.brush_radius
        self.show_status()

    def _group_words(self) -> str:
        """The active handle group in words: "handle group 2 of 3 (magenta)" (the window's colours)."""
        from ..deform.roles import handle as handle_role
        from ..viewer.render.palette import ROLE_COLOR_NAMES, role_rows

        sel = self.session.selection
        return (f"handle group {sel.active + 1} of {sel.n_groups} "
                f"({ROLE_COLOR_NAMES[role_rows(handle_role(sel.active))]})")

    @_editing
    def new_group(self) -> None:
        """New Handle Group (Ctrl+G): another handle, with its own colour and drag; its points selected next."""
        if self.gestures.busy:
            return
        self.polisher.cancel()
        if not self.session.selection.new_group():
            self.gestures.message = "The current handle group is still empty: select its cage points first"
        else:
            self.set_target(HANDLE)
            self.gestures.message = f"New {self._group_words()}: select its cage points (Select mode, Handle target)"
        self._changed()

    @_editing
    def next_group(self) -> None:
        """Next Handle Group (G): the next one (cycling) is the one selections and drags act on."""
        if self.gestures.busy:
            return
        self.session.selection.next_group()
        self.gestures.message = f"Now {self._group_words()}: selections and drags act on it"
        self._changed()

    @_editing
    def toggle_select_through(self) -> None:
        """Select Through (Alt+Z): selections also take the cage points hidden behind the shape (X-ray)."""
        g = self.gestures
        g.select_through = not g.select_through
        g.message = ("Select Through: selections also take the cage points hidden behind another part"
                     if g.select_through else "Select Through off: selections take the surface in sight")
        with self.state:
            self.state.through = g.select_through
        self.show_status()

    @_editing
    def toggle_stretch(self) -> None:
        """The stretch map (T): the shape coloured by its relative edge-length change, or not."""
        self.scene.set_stretch_visible(not self.scene.stretch_visible)
        self._changed()

    def reset_camera(self) -> None:
        """Frame Shape (F)."""
        self.scene.reset_camera()
        self.view.update()

    def _polished(self, message: str) -> None:
        """A polish was given to the session (or failed): shown, and said."""
        self.gestures.message = message
        self._changed()

    def _changed(self) -> None:
        with self.state:
            self.state.mirror = self.session.selection.symmetry == "x"
            self.state.stretch = self.scene.stretch_visible
        self.show_status()
        self.push()

    @_editing
    def save(self) -> None:
        """Save: the posed mesh written on the server, to the name typed (in the mesh's folder only,
        :func:`.server_files.save_target`), keeping what the file holds (texture coordinates, colours)."""
        from ..fileio.atomic import WriteError
        from .server_files import OutputPathError, save_target

        s = self.session
        try:
            target = save_target(s.path, self.state.save_name)
            notes = write_mesh(target, s.mesh.copy(vertices=s.shown_positions.copy()), like=s.path)
        except (OutputPathError, WriteError, OSError, ValueError) as e:
            self.gestures.message = f"Not saved: {e}"
        else:
            self.gestures.message = f"Saved the posed mesh to {target}" + (f" ({'; '.join(notes)})" if notes else "")
            print(f"hybridedit: saved the posed mesh to {target}", flush=True)
        self.show_status()

    @_editing
    def save_edit(self) -> None:
        """Save Edit: how the pose was made, beside the mesh (:func:`edit_path_of`), written atomically."""
        from ..deform.selection import SelectionError
        from ..fileio.atomic import WriteError

        s = self.session
        if s.path is None:
            return
        path = edit_path_of(s.path)
        try:
            save_edit(path, s.to_edit(), poses=s.poses.entries())
        except (SelectionError, ValueError, WriteError, OSError) as e:
            self.gestures.message = f"Could not save the edit: {e}"
        else:
            self.saved_edit = path
            self.gestures.message = f"Saved the edit to {path}"
            print(f"hybridedit: saved the edit to {path}", flush=True)
        self.show_status()

    def posed_ply(self) -> bytes:
        """The posed shape as a binary PLY file (the project's mesh writer, through a temporary file)."""
        s = self.session
        mesh = Mesh(s.shown_positions.copy(), s.mesh.faces, name=s.mesh.name)
        with tempfile.TemporaryDirectory(prefix="hybridedit-web-") as folder:
            out = Path(folder) / "posed.ply"
            write_mesh(out, mesh)
            return out.read_bytes()

    @_editing
    def download_mesh(self):
        """The Download button's attachment (the page saves it with ``utils.download``)."""
        return self.server.protocol.addAttachment(self.posed_ply())

    # ------------------------------------------------------------------ mouse
    @_editing
    def _on_mouse(self, iren, event: str) -> None:
        x, y = iren.GetEventPosition()
        g = self.gestures
        try:
            if event == "LeftButtonPressEvent":
                if g.mode != CAMERA:
                    self.polisher.cancel()  # (a selection or a drag: the polish of the last pose is stale)
                changed = g.press(x, y, bool(iren.GetShiftKey()), bool(iren.GetControlKey())) or g.mode in (DRAG, POSE)
            elif event == "MouseMoveEvent":
                changed = g.move(x, y)
            else:
                changed = g.release(x, y)
        except Exception as e:  # noqa: BLE001 -- said in the status line, the gesture abandoned
            g.message = f"{type(e).__name__}: {e}"
            self.session.cancel_drag()
            changed = True
        if event != "MouseMoveEvent":
            self._want_depth()
        if changed and event == "MouseMoveEvent":
            self._frame_due()
        elif changed:
            if event == "LeftButtonReleaseEvent" and g.mode in (DRAG, POSE):
                self.polisher.start()  # (the window's polish on release, in the background)
            self.show_status()
            self.push()
        elif event == "LeftButtonPressEvent" and g.message:
            self.show_status()

    # ------------------------------------------------------------------ server
    def _on_bind(self, wslink_server) -> None:
        if self.guard_pages:
            wslink_server.app.middlewares.append(token_middleware(self.token))

    def _on_connect(self, **_) -> None:
        print("hybridedit: a browser connected", flush=True)
        if self.session is None:
            self.view.update()  # (the shape read, shown while it is built)

    def url(self, host: str, port: int) -> str:
        shown = "127.0.0.1" if host in ("127.0.0.1", "localhost", "0.0.0.0", "") else host
        return f"http://{shown}:{port}/?secret={self.token}"

    def serve(self, host: str, port: int) -> None:
        """Serve until interrupted (prints the URL first)."""
        print(f"hybridedit web: open {self.url(host, port)}", flush=True)
        argv, sys.argv = sys.argv, sys.argv[:1]  # trame reads its own options from sys.argv: none of ours
        try:
            self.server.start(host=host, port=port, open_browser=False, show_connection_info=False,
                              disable_logging=True, timeout=0)
        finally:
            sys.argv = argv


def run(path: Path, *, host: str = "127.0.0.1", port: int = 8080, cage_size: int | float = CAGE_SIZE,
        edit=None, edit_path: str | None = None) -> int:
    """``hybridedit web``: read ``path`` (a file that cannot be read is said here, before serving), serve the
    page at once and build the shape behind it with progress (``edit`` replayed once built, an
    :class:`~hybridedit.Edit`); returns the exit status."""
    from ..fileio.meshfiles import read_document
    from ..viewer.model.look import shown_look
    from .token_guard import new_token

    path = Path(path)
    document = read_document(path)
    os.environ.setdefault("TRAME_DISABLE_V3_WARNING", "1")
    web = WebEditor(None, new_token(), name=path.name)
    web.ctrl.on_server_ready.add(lambda **_: web.open_file(path, mesh=document.mesh, look=shown_look(document),
                                                           cage_size=cage_size, edit=edit, edit_path=edit_path))
    web.serve(host, port)
    return 0
