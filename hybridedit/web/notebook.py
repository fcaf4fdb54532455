"""``he.widget``: the browser editor in a Jupyter cell, and the same session posed from Python.

The trame server runs as a task on the notebook kernel's own event loop (trame's
``exec_mode="task"``), so the browser's events and the notebook's cells take turns on one
thread: a cell that poses the shape never races a drag in the cell's view. The output is
an iframe of the editor's page (until the server listens, a page that opens it once it does).

The page sits on another origin than the notebook's (another port), where the browser
sends the page no cookie, so the widget does not use the page guard of ``hybridedit web``
(:mod:`.token_guard`): its page is trame's own files, and the session behind it (the
websocket: the pose, the images, every action) opens only with the token in the iframe's
URL (wslink's ``authKey``).
"""

from __future__ import annotations

import asyncio
import html
import json
import os
import socket
import sys
from pathlib import Path

import numpy as np

from ..core.mesh import Mesh
from ..defaults import CAGE_SIZE

__all__ = ["EditorWidget", "widget"]


class EditorWidget:
    """A shape being edited in a notebook cell (see :func:`widget`).

    Attributes
    ----------
    session : the editing model (:class:`~hybridedit.viewer.model.session.Session`): selection,
        history, edit files; what the cell's view shows.
    ready : an awaitable that ends (with this widget) once the cell's view can connect.
    """

    def __init__(self, source: str | os.PathLike | Mesh, *, cage_size: int | float = CAGE_SIZE,
                 height: int = 600) -> None:
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            raise RuntimeError("he.widget needs a running event loop, a Jupyter kernel's; "
                               "outside a notebook run `hybridedit web MESH`") from None
        from ..viewer.model.opening import open_session
        from .editor_app import WebEditor
        from .token_guard import new_token

        if not (isinstance(height, (int, np.integer)) and height > 0):
            raise ValueError(f"height must be a positive number of pixels, got {height!r}")
        os.environ.setdefault("TRAME_DISABLE_V3_WARNING", "1")
        opened = open_session(source if isinstance(source, Mesh) else Path(source), cage_size=cage_size)
        self.session = opened.session
        self.name = self.session.path.name if self.session.path else (self.session.mesh.name or "shape")
        self.height = int(height)
        self._web = WebEditor(self.session, new_token(), opened.up_axis, guard_pages=False)
        self._port = _free_port()  # known now: the cell's output names it before the server listens
        argv, sys.argv = sys.argv, sys.argv[:1]  # trame reads its options from sys.argv: the kernel's are not
        try:
            self._web.server.start(exec_mode="task", host="127.0.0.1", port=self._port, open_browser=False,
                                   show_connection_info=False, disable_logging=True, timeout=0)
        finally:
            sys.argv = argv
        self.ready = loop.create_task(self._until_ready())

    async def _until_ready(self) -> "EditorWidget":
        await self._web.server.ready
        return self

    # ------------------------------------------------------------------ what Python sees
    @property
    def editor(self):
        """The engine (:class:`~hybridedit.HybridEditor`): cage, binding, the pose's steps (read it;
        pose through :meth:`select` and :meth:`move`, which the view and undo follow)."""
        return self.session.editor

    @property
    def pose(self) -> np.ndarray:
        """The pose on display, (n, 3) float64 (a copy)."""
        return self.session.shown_positions.copy()

    @property
    def url(self) -> str:
        """The editor's page, with its token (it answers once :attr:`ready`)."""
        return self._web.url("127.0.0.1", self._port)

    # ------------------------------------------------------------------ posing from Python
    def select(self, *, roi=None, handle=None, space: str = "shape") -> None:
        """Choose the region that may move (``roi``) and the handle that follows :meth:`move`.

        Parameters
        ----------
        roi, handle : vertex indices (a list or an integer array) or a boolean mask; None keeps
            that part of the selection as it is.
        space : "shape" (indices of the shape's vertices: each takes the cage point it depends on
            most) or "cage" (cage point indices, as the view's selection takes them).

        One undo step, shown in the cell's view.

        Examples
        --------
        >>> x = w.pose[:, 0]                               # doctest: +SKIP
        >>> w.select(roi=x > 0.45, handle=x > 0.85)        # doctest: +SKIP
        """
        self._idle()
        s = self.session
        r = s.selection.roi if roi is None else self._cage_mask(roi, space, "roi")
        h = s.selection.handle if handle is None else self._cage_mask(handle, space, "handle")
        s.selection.replace(r, h, "select (Python)")
        self.refresh()

    def _cage_mask(self, chosen, space: str, name: str) -> np.ndarray:
        s = self.session
        if space not in ("shape", "cage"):
            raise ValueError(f'space must be "shape" or "cage", got {space!r}')
        n = s.mesh.n_vertices if space == "shape" else s.n_cage
        a = np.asarray(chosen)
        if a.dtype == bool:
            if a.shape != (n,):
                raise ValueError(f"{name}: a mask must have {n} entries (the {space}'s vertices), got {a.shape}")
            index = np.flatnonzero(a)
        elif a.size == 0 or np.issubdtype(a.dtype, np.integer):
            index = a.astype(np.int64).ravel()
            if index.size and (index.min() < 0 or index.max() >= n):
                raise ValueError(f"{name}: indices must be in 0..{n - 1} (the {space}'s vertices)")
        else:
            raise ValueError(f"{name}: give vertex indices or a boolean mask, got {a.dtype} values")
        mask = np.zeros(s.n_cage, dtype=bool)
        mask[s.dominant[index] if space == "shape" else index] = True
        return mask

    def move(self, translate=None, *, axis=None, degrees: float = 0.0) -> np.ndarray:
        """Drag the handle by code as a mouse drag does: to ``translate`` and turned ``degrees``
        about ``axis`` through the handle's centre, settled as at a release; one undo step. (Not
        polished: the pose returned is the one kept; a drag in the view is polished on release.)

        Returns the pose, (n, 3) (a copy).

        Raises
        ------
        SelectionError
            No handle is selected.
        """
        from ..core.transforms import rigid_transform

        self._idle()
        s = self.session
        T0 = s.begin_drag()
        D = rigid_transform(translate, axis, degrees, center=s.handle_centroid())
        s.drag_to(D @ T0)
        if not np.all(np.isfinite(s.shape_positions)):
            s.cancel_drag()
            self.refresh()
            raise ValueError("the move made the shape non-finite; it was undone")
        s.end_drag("move (Python)")
        s.finish_settle()
        self.refresh()
        return self.pose

    def undo(self) -> bool:
        """Undo the last step (the view's or Python's); False when there is none."""
        self._idle()
        done = self.session.undo()
        self.refresh()
        return done

    def redo(self) -> bool:
        """Redo the step undone last; False when there is none."""
        self._idle()
        done = self.session.redo()
        self.refresh()
        return done

    def _idle(self) -> None:
        if self._web.gestures.busy:
            raise RuntimeError("a gesture in the cell's view is under way; release the mouse first")
        self._web.polisher.cancel()  # (a polish of the view's last drag is stale once Python changes things)

    def refresh(self) -> None:
        """Show the session as it is now in the cell's view (after changing it through :attr:`session`)."""
        self._web.show_status()
        self._web.push()

    # ------------------------------------------------------------------ files
    def save(self, path: str | os.PathLike) -> list[str]:
        """Write the pose on display to a mesh file (any format the editor writes), keeping what the
        opened file holds (texture coordinates, materials, colours); atomically. Returns the notes
        of what a conversion could not carry."""
        from ..fileio.meshfiles import write_mesh

        s = self.session
        return write_mesh(Path(path), s.mesh.copy(vertices=s.shown_positions.copy()), like=s.path)

    def save_edit(self, path: str | os.PathLike) -> Path:
        """Write how the pose was made (an edit file ``hybridedit deform`` replays); returns the path."""
        from ..fileio.editfile import save_edit

        p = Path(path)
        save_edit(p, self.session.to_edit(), poses=self.session.poses.entries())
        return p

    def close(self):
        """Stop the server (the cell's view goes dark); returns an awaitable of the stop."""
        self._web.polisher.close()
        self._web.plotter.close()
        return asyncio.ensure_future(self._web.server.stop())

    # ------------------------------------------------------------------ the cell's output
    def _iframe(self) -> str:
        """The view in the cell. Before the server listens it is a page of its own that asks for the
        editor's every quarter second and opens it once it answers (a notebook shows the cell's
        output at once, while the server only starts when the cell has ended)."""
        style = f"border: none; width: 100%; height: {self.height}px"
        title = html.escape(f"hybridedit: {self.name}")
        if self.ready.done():
            return f'<iframe src="{html.escape(self.url)}" title="{title}" style="{style}"></iframe>'
        waiting = (f"<p style='font: 14px sans-serif'>hybridedit: starting the editor of {html.escape(self.name)}"
                   f"&hellip;</p><script>{_OPEN_WHEN_UP % json.dumps(self.url)}</script>")
        return f'<iframe srcdoc="{html.escape(waiting)}" title="{title}" style="{style}"></iframe>'

    def _failed(self) -> str | None:
        if not self.ready.done():
            return None
        e = self.ready.exception()
        return None if e is None else f"{type(e).__name__}: {e}"

    def _repr_html_(self) -> str:
        failed = self._failed()
        if failed:
            return f"<p>hybridedit: the editor of {html.escape(self.name)} could not start: {html.escape(failed)}</p>"
        return self._iframe()

    def __repr__(self) -> str:
        s = self.session
        state = "failed" if self._failed() else "ready" if self.ready.done() else "starting"
        return f"<EditorWidget {self.name}: {s.mesh.n_vertices:,} vertices, cage {s.n_cage:,}; {state}>"


#: the waiting page's script: ask for the editor's page until it answers, then open it
_OPEN_WHEN_UP = """const url = %s;
function ask() { fetch(url, {mode: "no-cors", cache: "no-store"}).then(() => location.replace(url), () => setTimeout(ask, 250)); }
ask();"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def widget(source: str | os.PathLike | Mesh, *, cage_size: int | float = CAGE_SIZE,
           height: int = 600) -> EditorWidget:
    """The editor in a Jupyter cell: the browser editor of ``hybridedit web`` on a shape, and the
    same session posed from Python while the view is open.

    Parameters
    ----------
    source : a mesh file, or a :class:`~hybridedit.Mesh`.
    cage_size : the cage's vertex count (int) or fraction of the shape's (float).
    height : the view's height in the cell, in pixels.

    Returns
    -------
    EditorWidget
        Shown by the cell it ends; ``w.pose`` (n, 3), ``w.select(...)``, ``w.move(...)``,
        ``w.undo()``, ``w.save(path)``, ``w.save_edit(path)``, ``w.session``, ``w.editor``.

    Raises
    ------
    RuntimeError
        No event loop runs (not in a Jupyter kernel).
    MeshError, MeshFileError, ValueError, OSError
        The file cannot be read or bound.

    Examples
    --------
    >>> import hybridedit as he                       # doctest: +SKIP
    >>> w = he.widget("data/creature.ply"); w         # doctest: +SKIP
    >>> x = w.pose[:, 0]                              # doctest: +SKIP
    >>> w.select(roi=x > 0.45, handle=x > 0.85)       # doctest: +SKIP
    >>> w.move([0.0, 0.2, 0.0]).shape                 # doctest: +SKIP
    (100576, 3)
    """
    return EditorWidget(source, cage_size=cage_size, height=height)
