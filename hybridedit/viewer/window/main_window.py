"""The main window: a QMainWindow and the collaborators that do its jobs, made and wired here.

The editing state (selection, pose, polished pose, undo) lives in :class:`~..model.session.Session`;
the window holds the session on display. Each collaborator has one job and takes the window as the
narrow protocol its module declares (what it needs of the others), and where it draws, the scene and
the view themselves; signals connect the threads' results to the collaborator that shows them.
"""

from __future__ import annotations

from qtpy import QtGui, QtWidgets

from ...defaults import CAGE_SIZE
from ..input.drags import DragFrames
from ..input.mouse_gestures import ViewController
from ..jobs.build_jobs import BuildJobs
from ..jobs.polish_scheduler import PolishScheduler
from ..model.selection_masks import ROI
from ..model.session import Session
from ..render.scene import Scene
from ..render.view import View
from .actions import ActionSet
from .autosave import Autosave
from .cage_size_box import CageSizeControl
from .dialogs import InfoDialogs
from .file_actions import FileActions
from .file_drops import FileDrops
from .first_steps import FirstSteps
from .limb_posing import LimbPosing
from .pose_panel import PosePanel
from .posing import Posing
from .scene_sync import SceneSync
from .selecting import Selecting
from .shape_loading import ShapeLoading
from .status_bar import StatusBar
from .undo_commands import UndoCommands
from .unsaved_mark import UnsavedMark
from .view_options import ViewOptions


class MainWindow(QtWidgets.QMainWindow):
    """The hybridedit editor window.

    Parameters
    ----------
    cage_size : initial cage size (int vertex count or float fraction of the shape).

    Attributes
    ----------
    session : the shape being edited, or None (set by ``loading``).
    view, scene : the 3D view (:class:`~..render.view.View`) and its actors (:class:`~..render.scene.Scene`).
    controller : the mouse on the view (:class:`~..input.mouse_gestures.ViewController`).
    dragging : the drags' frames and settle (:class:`~..input.drags.DragFrames`).
    jobs : the cage and binding builds (:class:`~..jobs.build_jobs.BuildJobs`).
    polisher : polish on release (:class:`~..jobs.polish_scheduler.PolishScheduler`).
    loading : opening and rebuilding, the preview while building, a build installed
        (:class:`~.shape_loading.ShapeLoading`).
    selecting : the selection, its target and handle groups (:class:`~.selecting.Selecting`).
    posing : the guard, what follows a drag, polish results (:class:`~.posing.Posing`).
    sync : the scene kept in step with the session (:class:`~.scene_sync.SceneSync`).
    undo_commands : undo, redo, reset pose (:class:`~.undo_commands.UndoCommands`).
    options : the Mode and View menus' settings and the brush box (:class:`~.view_options.ViewOptions`).
    files : the file actions (:class:`~.file_actions.FileActions`).
    dialogs : the information dialogs (:class:`~.dialogs.InfoDialogs`).
    unsaved : the unsaved-pose mark and the title (:class:`~.unsaved_mark.UnsavedMark`).
    cage_control : the toolbar's cage size box (:class:`~.cage_size_box.CageSizeControl`).
    actions_ : the actions by name, the menus and the toolbar (:class:`~.actions.ActionSet`).
    status : the status bar and the message log (:class:`~.status_bar.StatusBar`).
    drops : files dropped on the window (:class:`~.file_drops.FileDrops`).
    first_steps : the hint on the view until the first selection (:class:`~.first_steps.FirstSteps`).
    limb_posing : the Pose tool (:class:`~.limb_posing.LimbPosing`).
    autosave : the unsaved pose kept for recovery, and recovered (:class:`~.autosave.Autosave`).
    pose_panel : Pose ▸ Keep Pose and the Poses panel of kept poses (:class:`~.pose_panel.PosePanel`).
    """

    def __init__(self, cage_size: int | float = CAGE_SIZE) -> None:
        super().__init__()
        self.session: Session | None = None
        self.files = FileActions(self, parent=self)
        self.jobs = BuildJobs(self, parent=self)
        self.dialogs = InfoDialogs(self, parent=self)
        self.polisher = PolishScheduler(self)
        self.unsaved = UnsavedMark(self, self)
        self.unsaved.update_title()
        self.view = View(self)
        self.setCentralWidget(self.view)
        self.scene = Scene(self.view.plotter)
        self.dragging = DragFrames(self, self.scene, self.view, parent=self)
        self.posing = Posing(self)
        self.sync = SceneSync(self)
        self.selecting = Selecting(self)
        self.undo_commands = UndoCommands(self)
        self.options = ViewOptions(self)
        self.loading = ShapeLoading(self)
        self.limb_posing = LimbPosing(self)
        self.controller = ViewController(self.view, self.scene, self.selecting, self.dragging, self.limb_posing)
        self.cage_control = CageSizeControl(lambda: self.session.mesh.n_vertices if self.session else None)
        self.pose_panel = PosePanel(self, self)
        self.actions_ = ActionSet(self, self)
        # (after the toolbar: its widgets come after the toolbar's in the keyboard focus order)
        self.status = StatusBar(self, self)
        self.cage_control.set_value(cage_size)
        self.drops = FileDrops(self, self)
        self.first_steps = FirstSteps(self)
        self.autosave = Autosave(self, self)
        # the threads' results and the view's frames, to the collaborators that show them
        self.jobs.busy_changed.connect(lambda _busy: self.actions_.refresh())
        self.polisher.succeeded.connect(self.posing.show_polish)
        self.polisher.failed.connect(self.posing.polish_failed)
        self.view.rendered.connect(self.options.on_rendered)
        self.selecting.set_target(ROI)
        self.actions_.refresh()
        self.resize(1280, 900)

    def closeEvent(self, ev: QtGui.QCloseEvent) -> None:  # noqa: N802
        """Quit, unless the unsaved-pose question is cancelled (:meth:`~.file_actions.FileActions.keep_work`);
        the drag frames, the polish and the build end first, and the recovery file goes (a clean quit)."""
        if not self.files.keep_work("quitting"):
            ev.ignore()
            return
        self.autosave.quit_cleanly()
        self.dragging.stop()
        self.polisher.wait()
        self.jobs.wait()
        self.status.stop()
        self.view.close()
        super().closeEvent(ev)
