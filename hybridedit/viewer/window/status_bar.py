"""The window's status bar and message log: the latest message, the status fields (timing, sizes,
selection, edge error), the log of every message, error boxes and yes/no questions.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np
from qtpy import QtCore, QtGui, QtWidgets

from ..model.crash_reports import failure_message, session_details, write_crash_report
from .interfaces import Busy
from .status_widgets import MessageLine, StatusField, StatusRow

if TYPE_CHECKING:
    from ..model.session import Session


def _fmt(n: int) -> str:
    return f"{n:,}"


@runtime_checkable
class DragStats(Protocol):
    """The drags as the status bar sees them (:class:`~..input.drags.DragFrames`)."""

    error: float | None
    @property
    def frame_shown_at(self) -> float: ...
    @property
    def engine_ms(self) -> float: ...
    @property
    def thread_ms(self) -> float: ...


@runtime_checkable
class RenderStats(Protocol):
    """The 3D view as the status bar sees it: its frame rate and the latest render's time."""

    @property
    def render_seconds(self) -> float: ...
    def display_fps(self) -> float: ...


@runtime_checkable
class Progress(Protocol):
    """The build jobs as the status bar sees them: their progress bar and Cancel button go in its row."""

    def place_in(self, row: StatusRow) -> None: ...


@runtime_checkable
class StatusHost(Protocol):
    """What :class:`StatusBar` reads of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def dragging(self) -> DragStats: ...
    @property
    def view(self) -> RenderStats: ...
    @property
    def polisher(self) -> Busy: ...
    @property
    def jobs(self) -> Progress: ...
    @property
    def actions_(self) -> Mapping[str, QtGui.QAction]: ...  # View ▸ Messages


class StatusBar:
    """The status bar and the message log of a :class:`~.main_window.MainWindow`: it shows what the
    window says (messages, errors, questions) and, a few times a second, the state of the session,
    the drags, the view and the polish in its fields.

    Parameters
    ----------
    window : what the fields show (:class:`StatusHost`).
    parent : the main window whose status bar and dock area are used, and the parent of the boxes.

    Attributes
    ----------
    message_label : the latest message (:class:`~.status_widgets.MessageLine`).
    time_label, size_label, sel_label, error_label : the fields: timing, sizes, selection, edge error.
    row : the row that places the fields (and the build's progress bar) in the width there is.
    log, log_dock : every message of this session, with its time, and the dock it shows in.
    last_error : the text of the latest error shown, or None.
    timer : the tick that shows the timing and a drag's edge error.
    """

    def __init__(self, window: StatusHost, parent: QtWidgets.QMainWindow) -> None:
        self.w = window
        self.parent = parent
        self.last_error: str | None = None
        self.error_box: QtWidgets.QMessageBox | None = None
        sb = parent.statusBar()
        # the latest message on two lines, cut with "…" when longer: whole in its tooltip, and a click shows
        # the message log (View > Messages keeps them all); its size never changes with the text
        self.message_label = MessageLine(2, hint="Click for every message (View ▸ Messages)")
        self.message_label.clicked.connect(self.show_log)
        sb.addWidget(self.message_label, 1)
        # the fix a message offers, one click away beside it (e.g. Free Around Handle when a drag would tear)
        self.fix_button = QtWidgets.QToolButton()
        self.fix_button.setToolButtonStyle(QtCore.Qt.ToolButtonStyle.ToolButtonTextOnly)
        self.fix_button.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)  # (the keyboard stays with the view)
        sb.addWidget(self.fix_button)
        self.fix_button.hide()
        # fields of fixed size: a new frame rate or edge error while dragging re-lays nothing out; the row
        # shows those that fit its width, by priority (edge error, selection, sizes, timing), never one over
        # another; the build's progress bar and Cancel button come first
        self.time_label = StatusField(template="00 fps · frame 000 ms · render 000 ms")
        self.size_label = StatusField("no shape")
        self.sel_label = StatusField()
        self.error_label = StatusField(template="edge error 00.00 %")
        # (the row takes no more than what fits beside the message at its narrowest: the rest is the message's)
        self.row = StatusRow(reserve=lambda: self.message_label.minimumWidth() + 40)
        for priority, field in ((4, self.time_label), (3, self.size_label), (2, self.sel_label), (1, self.error_label)):
            self.row.add(field, priority)
        self.w.jobs.place_in(self.row)  # the build's progress bar and Cancel button
        sb.addPermanentWidget(self.row)
        self.log = QtWidgets.QPlainTextEdit()
        self.log.setReadOnly(True)
        self.log.setMaximumBlockCount(2000)
        dock = QtWidgets.QDockWidget("Messages", parent)
        dock.setObjectName("messages")
        dock.setWidget(self.log)
        dock.visibilityChanged.connect(lambda v: self.w.actions_["messages"].setChecked(v))
        parent.addDockWidget(QtCore.Qt.DockWidgetArea.BottomDockWidgetArea, dock)
        dock.hide()
        self.log_dock = dock
        self.timer = QtCore.QTimer(parent)
        self.timer.setInterval(250)
        self.timer.timeout.connect(self.tick)
        self.timer.start()

    # ------------------------------------------------------------------ messages
    def show_error(self, title: str, text: str) -> None:
        """Tell the user about a problem (a non-blocking window-modal message box, and the message log)."""
        self.last_error = text
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Warning, title, text,
                                    QtWidgets.QMessageBox.StandardButton.Ok, self.parent)
        box.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        self.error_box = box
        box.open()
        self.message(f"{title}: {text}" if text else title)

    def report_crash(self, error: BaseException, *, what: str, context: str, kept: str | None = None,
                     details: dict | None = None) -> Path | None:
        """An unexpected error the window recovered from: its crash report written (with the session's sizes
        and ``details``) and one line in the status bar and the message log naming what failed, what was
        kept and the report (no box: the window is usable at once). Returns the report's path, or None
        when it could not be written (the line says so).

        Parameters
        ----------
        error : the exception, with its traceback.
        what : the line's start ("The drag frame failed"); context : the report's ("drag frame").
        kept : what the window kept ("the last good pose is kept"), or None.
        details : more for the report, ``{name: value}``.
        """
        report = write_crash_report(error, context=context,
                                    details={**session_details(self.w.session), **(details or {})})
        text = failure_message(what, error, report, kept=kept)
        self.last_error = text
        self.message(text)
        return report

    def confirm(self, title: str, text: str) -> bool:
        """Ask a yes/no question (No is the default)."""
        Btn = QtWidgets.QMessageBox.StandardButton
        r = QtWidgets.QMessageBox.question(self.parent, title, text, Btn.Yes | Btn.No, Btn.No)
        return r == Btn.Yes

    def message(self, text: str, *, fix: QtGui.QAction | None = None) -> None:
        """Show a message in the status bar until the next one (or until it is out of date): what fits in two
        lines, the rest cut with "…" and whole in its tooltip; and log it. ``fix``: the action that does what
        the message suggests, offered as a button beside it while the message shows."""
        self.message_label.setText(text)
        self._offer(fix)
        if text:
            self.log.appendPlainText(f"{time.strftime('%H:%M:%S')}  {text}")

    def current_message(self) -> str:
        """The message on show in the status bar (whole, also where it is cut on screen)."""
        return self.message_label.text()

    def clear_message(self) -> None:
        """The state changed: the message on show may no longer be true."""
        self.message_label.setText("")
        self._offer(None)

    def offered_fix(self) -> QtGui.QAction | None:
        """The action offered beside the message on show, or None."""
        return self.fix_button.defaultAction() if self.fix_button.isVisible() else None

    def _offer(self, fix: QtGui.QAction | None) -> None:
        if fix is None:
            self.fix_button.hide()
            return
        if self.fix_button.defaultAction() is not fix:
            self.fix_button.setDefaultAction(fix)
        self.fix_button.show()

    def toggle_log(self) -> None:
        """View ▸ Messages: the message log shown or hidden."""
        self.log_dock.setVisible(self.w.actions_["messages"].isChecked())

    def show_log(self) -> None:
        """A click on the status bar's message: the message log, its latest line in sight."""
        self.log_dock.show()
        self.log.verticalScrollBar().setValue(self.log.verticalScrollBar().maximum())

    # ------------------------------------------------------------------ the fields
    def _show_sizes(self, n_vertices: int, n_faces: int, n_cage: int | None) -> None:
        """The shape's and the cage's sizes (``n_cage`` None: the cage is being built)."""
        cage = "…" if n_cage is None else f"{_fmt(n_cage)} v"
        self.size_label.setText(f"shape {_fmt(n_vertices)} v / {_fmt(n_faces)} f · cage {cage}")

    def show_building(self, n_vertices: int, n_faces: int) -> None:
        """A new shape is read and its cage is being built: its sizes, and no selection or edge error yet."""
        self._show_sizes(n_vertices, n_faces, None)
        self.sel_label.setText("")
        self.error_label.setText("")

    def show_session(self) -> None:
        """The sizes and the selection's counts of the session (or "no shape")."""
        s = self.w.session
        if s is None:
            self.size_label.setText("no shape")
            self.sel_label.setText("")
            return
        self._show_sizes(s.mesh.n_vertices, s.mesh.n_faces, s.editor.cage.n_vertices)
        sel = s.selection
        h = sel.all_handles
        n_roi = int(np.count_nonzero(sel.roi & ~h))
        n_h = int(np.count_nonzero(sel.handle))
        n_f = int(np.count_nonzero(~sel.roi & ~h))
        group = f" (group {sel.active + 1} of {sel.n_groups})" if sel.n_groups > 1 else ""
        self.sel_label.setText(f"ROI {n_roi} · handle {n_h}{group} · fixed {n_f}")

    def show_edge_error(self, err: float | None) -> None:
        """The edge error (percent) of the pose on display, marked when it is polished; None: no shape."""
        if err is None:
            self.error_label.setText("")
            return
        self.w.dragging.error = None
        s = self.w.session
        polished = s is not None and s.polished is not None
        self.error_label.setText(f"edge error {err:.2f} %{' (polished)' if polished else ''}")

    def show_polishing(self) -> None:
        """A polish runs (the timing field says so until it ends)."""
        self.time_label.setText("polishing…")

    def tick(self) -> None:
        """The status timer: the edge error a drag measured, and the timing (or "polishing…")."""
        if self.w.dragging.error is not None:
            self.show_edge_error(self.w.dragging.error)  # (which clears it)
        s = self.w.session
        if s is None or s.settling:
            return
        if self.w.polisher.busy:
            self.show_polishing()
            return
        self.time_label.setText(self.timing_text())

    def stop(self) -> None:
        """No more ticks (the window closes)."""
        self.timer.stop()

    def timing_text(self) -> str:
        """Frames of a drag shown per second first (what the eye gets), then what the frame thread spent on
        the latest frame (the engine's solve, and the moving region's normals and edge error; the split
        is in the field's tooltip), and the render's time; a brush stroke or a turn of the camera renders
        too, but that rate is not a drag's: "idle"."""
        w = self.w
        d = w.dragging
        dragging = time.perf_counter() - d.frame_shown_at <= 1.0
        fps = w.view.display_fps() if dragging else 0.0
        parts = [f"{fps:.0f} fps" if fps > 0 else "idle"]
        if d.engine_ms > 0:
            parts.append(f"frame {d.thread_ms:.0f} ms")
            self.time_label.setToolTip(
                f"The latest drag frame: {d.thread_ms:.1f} ms on the frame thread, of which the engine's solve "
                f"{d.engine_ms:.1f} ms and the moving region's points, normals and edge error "
                f"{max(d.thread_ms - d.engine_ms, 0.0):.1f} ms; the render runs beside it")
        if w.view.render_seconds > 0:
            parts.append(f"render {w.view.render_seconds * 1e3:.0f} ms")
        return " · ".join(parts)
