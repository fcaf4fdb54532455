"""The main window: the assembly of its parts, its start and its close; it wires Qt to the session.

The editing state (selection, pose, polished pose, undo) lives in :class:`~..model.session.Session`. The
window's jobs are mixins, one module each: the actions, menus and toolbar in :mod:`.actions`; the
selecting in :mod:`.selecting` and handle groups in
:mod:`.handle_groups`; drags, settle and polish in :mod:`.posing`; the mode and what is drawn in
:mod:`.view_options`; the scene kept in step in :mod:`.scene_sync`; opening and installing builds in
:mod:`.shape_loading`; undo in :mod:`.undo_commands`; dropped files in :mod:`.file_drops`.
Its helpers, given the window as the narrow protocol each declares: the status bar and message log in
:mod:`.status_bar`; the unsaved mark and the title in :mod:`.unsaved_mark`; file actions in :mod:`.file_actions`;
cage and binding builds in :mod:`..jobs.build_jobs`; a drag's frames and settle in :mod:`..input.drags`; polish
scheduling in :mod:`..jobs.polish_scheduler`; the information dialogs in :mod:`.dialogs`; and the drawing in
:mod:`..render.scene`, mouse gestures in :mod:`..input.mouse_gestures`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from qtpy import QtGui, QtWidgets

from ...defaults import CAGE_SIZE
from .actions import ActionsMixin
from ..jobs.build_jobs import BuildJobs
from .dialogs import InfoDialogs
from ..input.drags import DragFrames
from .file_drops import DropsMixin
from .file_actions import FileActions
from .handle_groups import HandleGroupsMixin
from ..input.mouse_gestures import ViewController
from .shape_loading import LoadingMixin
from ..jobs.polish_scheduler import PolishScheduler
from .posing import PosingMixin
from .scene_sync import RefreshMixin
from ..render.scene import Scene
from .selecting import SelectingMixin
from ..model.selection_masks import ROI
from ..model.session import Session
from .status_bar import StatusBar
from .undo_commands import UndoMixin
from .unsaved_mark import UnsavedMark
from ..render.view import View
from .view_options import ViewSettingsMixin
from ..jobs.polish_worker import PolishOutcome

if TYPE_CHECKING:
    from ...core.mesh import Mesh


class MainWindow(ActionsMixin, SelectingMixin, HandleGroupsMixin, PosingMixin, ViewSettingsMixin,
                 RefreshMixin, LoadingMixin, UndoMixin, DropsMixin, QtWidgets.QMainWindow):
    """The hybridedit editor window.

    Parameters
    ----------
    cage_size : initial cage size (int vertex count or float fraction of the shape).

    Attributes
    ----------
    session : the shape being edited, or None.
    files : the file actions (:class:`~.file_actions.FileActions`).
    jobs : the cage and binding builds (:class:`~..jobs.build_jobs.BuildJobs`).
    dialogs : the information dialogs (:class:`~.dialogs.InfoDialogs`).
    dragging : the drags' frames and settle (:class:`~..input.drags.DragFrames`).
    polisher : polish on release (:class:`~..jobs.polish_scheduler.PolishScheduler`).
    status : the status bar and the message log (:class:`~.status_bar.StatusBar`).
    unsaved : the unsaved-pose mark and the title (:class:`~.unsaved_mark.UnsavedMark`).
    """

    def __init__(self, cage_size: int | float = CAGE_SIZE) -> None:
        super().__init__()
        self.session: Session | None = None
        #: while a new shape read is shown and its cage is built: (the session put aside,) (see preview_shape)
        self._aside: tuple[Session | None] | None = None
        self._previewed: Mesh | None = None  # the shape shown by preview_shape
        self.settle_on_release = True
        self.last_polish: PolishOutcome | None = None
        self._rrms_full = True  # the next measure must walk every edge (the pose changed outside a drag)
        self._generation = -1  # the session's engine generation the scene shows
        # each helper takes the window as the narrow protocol it declares (FileHost, BuildHost, InfoSource,
        # DragHost) and, where it draws, the scene and the view themselves
        self.files = FileActions(self, parent=self)
        self.jobs = BuildJobs(self, parent=self)
        self.jobs.busy_changed.connect(lambda _busy: self._update_actions())
        self.dialogs = InfoDialogs(self, parent=self)
        self.polisher = PolishScheduler(self)
        self.polisher.succeeded.connect(self._polish_succeeded)
        self.polisher.failed.connect(lambda m: self.status.message(f"Polish failed: {m}"))
        self.unsaved = UnsavedMark(self, self)
        self.unsaved.update_title()

        self.view = View(self)
        self.setCentralWidget(self.view)
        self.scene = Scene(self.view.plotter)
        self.dragging = DragFrames(self, self.scene, self.view, parent=self)
        self.controller = ViewController(self.view, self.scene, self)
        self.actions_: dict[str, QtGui.QAction] = {}
        self._make_actions()
        self._make_menus()
        self._make_toolbar()
        self.status = StatusBar(self, self)
        self.jobs.place_in(self.status.row)  # the build's progress bar and Cancel button
        self.set_cage_size(cage_size)
        self.setAcceptDrops(True)
        self.view.rendered.connect(self._on_rendered)
        self.target = ROI
        self._set_target(ROI)
        self._update_actions()
        self.resize(1280, 900)

    # ================================================================== cage size control
    def cage_size(self) -> int | float:
        """The cage size set in the toolbar: an int vertex count or a float fraction."""
        return self.cage_control.value()

    def set_cage_size(self, size: int | float, *, of_shape: bool = False) -> None:
        """Show ``size`` in the toolbar; ``of_shape``: it is the size of the cage on display (a vertex count
        of that kind is not carried over to another shape: see :mod:`..jobs.build_jobs`)."""
        self.cage_control.set_value(size, of_shape=of_shape)

    def cage_size_of_shape(self) -> bool:
        """The toolbar shows the cage size of the shape on display, not a size chosen since."""
        return self.cage_control.of_shape

    # ================================================================== closing
    def closeEvent(self, ev: QtGui.QCloseEvent) -> None:  # noqa: N802
        """Quit, unless the unsaved-pose question is cancelled (:meth:`~.file_actions.FileActions.keep_work`);
        the drag frames, the polish and the build end first."""
        if not self.files.keep_work("quitting"):
            ev.ignore()
            return
        self.dragging.stop()
        self.polisher.wait()
        self.jobs.wait()
        self.status.stop()
        self.view.close()
        super().closeEvent(ev)
