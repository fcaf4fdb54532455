"""The window's status bar and message log: the latest message, the status fields (timing, sizes,
selection, edge error), the log of every message, error boxes and yes/no questions; and
:func:`guarded`, which shows a slot's unexpected error there instead of a traceback.
"""

from __future__ import annotations

import functools
import time
from typing import Callable

import numpy as np
from qtpy import QtCore, QtWidgets

from .status_widgets import MessageLine, StatusField, StatusRow


def guarded(method: Callable) -> Callable:
    """Run a UI slot and show any unexpected error in a message box instead of a traceback."""

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        try:
            return method(self, *args, **kwargs)
        except Exception as e:  # noqa: BLE001
            self.show_error("Unexpected error", f"{e.__class__.__name__}: {e}")
            return None

    return wrapper


def _fmt(n: int) -> str:
    return f"{n:,}"


class StatusBarMixin:
    """The status bar and the message log of a :class:`~.main_window.MainWindow` (a mixin).

    The fields show the ``session`` (sizes, selection), the ``dragging`` and the ``view`` (timing,
    edge error while dragging) and the ``polisher``; the build ``jobs`` put their progress bar in the
    row; View ▸ Messages (``actions_["messages"]``) shows the log.
    """

    def _make_statusbar(self) -> None:
        sb = self.statusBar()
        # the latest message on two lines, cut with "…" when longer: whole in its tooltip, and a click shows
        # the message log (View > Messages keeps them all); its size never changes with the text
        self.message_label = MessageLine(2, hint="Click for every message (View ▸ Messages)")
        self.message_label.clicked.connect(self._show_messages)
        sb.addWidget(self.message_label, 1)
        # fields of fixed size: a new frame rate or edge error while dragging re-lays nothing out; the row
        # shows those that fit its width, by priority (edge error, selection, sizes, timing), never one over
        # another; the build's progress bar and Cancel button come first
        self.time_label = StatusField(template="00 fps · frame 000 ms · render 000 ms")
        self.size_label = StatusField("no shape")
        self.sel_label = StatusField()
        self.error_label = StatusField(template="edge error 00.00 %")
        # (the row takes no more than what fits beside the message at its narrowest: the rest is the message's)
        self.status_row = StatusRow(reserve=lambda: self.message_label.minimumWidth() + 40)
        for priority, w in ((4, self.time_label), (3, self.size_label), (2, self.sel_label), (1, self.error_label)):
            self.status_row.add(w, priority)
        self.jobs.place_in(self.status_row)  # the build's progress bar and Cancel button
        sb.addPermanentWidget(self.status_row)
        self.log = QtWidgets.QPlainTextEdit()
        self.log.setReadOnly(True)
        self.log.setMaximumBlockCount(2000)
        dock = QtWidgets.QDockWidget("Messages", self)
        dock.setObjectName("messages")
        dock.setWidget(self.log)
        dock.visibilityChanged.connect(lambda v: self.actions_["messages"].setChecked(v))
        self.addDockWidget(QtCore.Qt.DockWidgetArea.BottomDockWidgetArea, dock)
        dock.hide()
        self.log_dock = dock

    # ------------------------------------------------------------------ messages
    def show_error(self, title: str, text: str) -> None:
        """Tell the user about a problem (a non-blocking window-modal message box, and the message log)."""
        self.last_error = text
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Warning, title, text,
                                    QtWidgets.QMessageBox.StandardButton.Ok, self)
        box.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        self._error_box = box
        box.open()
        self.message(f"{title}: {text}" if text else title)

    def confirm(self, title: str, text: str) -> bool:
        """Ask a yes/no question (No is the default)."""
        Btn = QtWidgets.QMessageBox.StandardButton
        r = QtWidgets.QMessageBox.question(self, title, text, Btn.Yes | Btn.No, Btn.No)
        return r == Btn.Yes

    def message(self, text: str) -> None:
        """Show a message in the status bar until the next one (or until it is out of date): what fits in two
        lines, the rest cut with "…" and whole in its tooltip; and log it."""
        self.message_label.setText(text)
        if text:
            self.log.appendPlainText(f"{time.strftime('%H:%M:%S')}  {text}")

    def current_message(self) -> str:
        """The message on show in the status bar (whole, also where it is cut on screen)."""
        return self.message_label.text()

    def clear_message(self) -> None:
        """The state changed: the message on show may no longer be true."""
        self.message_label.setText("")

    def _toggle_messages(self) -> None:
        self.log_dock.setVisible(self.actions_["messages"].isChecked())

    def _show_messages(self) -> None:
        """A click on the status bar's message: the message log, its latest line in sight."""
        self.log_dock.show()
        self.log.verticalScrollBar().setValue(self.log.verticalScrollBar().maximum())

    # ------------------------------------------------------------------ the fields
    def _show_sizes(self, n_vertices: int, n_faces: int, n_cage: int | None) -> None:
        """The shape's and the cage's sizes (``n_cage`` None: the cage is being built)."""
        cage = "…" if n_cage is None else f"{_fmt(n_cage)} v"
        self.size_label.setText(f"shape {_fmt(n_vertices)} v / {_fmt(n_faces)} f · cage {cage}")

    def _update_labels(self) -> None:
        """The sizes and the selection's counts of the session (or "no shape")."""
        s = self.session
        if s is None:
            self.size_label.setText("no shape")
            self.sel_label.setText("")
            return
        self._show_sizes(s.mesh.n_vertices, s.mesh.n_faces, s.editor.cage.n_vertices)
        h = s.all_handles
        n_roi = int(np.count_nonzero(s.roi & ~h))
        n_h = int(np.count_nonzero(s.handle))
        n_f = int(np.count_nonzero(~s.roi & ~h))
        group = f" (group {s.active + 1} of {s.n_groups})" if s.n_groups > 1 else ""
        self.sel_label.setText(f"ROI {n_roi} · handle {n_h}{group} · fixed {n_f}")

    def _show_error_value(self, err: float) -> None:
        """The edge error (percent) of the pose on display, marked when it is polished."""
        self.dragging.error = None
        polished = self.session is not None and self.session.polished is not None
        self.error_label.setText(f"edge error {err:.2f} %{' (polished)' if polished else ''}")

    def _tick(self) -> None:
        """The status timer: the edge error a drag measured, and the timing (or "polishing…")."""
        if self.dragging.error is not None:
            self._show_error_value(self.dragging.error)  # (which clears it)
        if self.session is None or self.session.settling:
            return
        if self.polisher.busy:
            self.time_label.setText("polishing…")
            return
        self.time_label.setText(self.timing_text())

    def timing_text(self) -> str:
        """Frames of a drag shown per second first (what the eye gets), then what the frame thread spent on
        the latest frame (the engine's solve, and the moving region's normals and edge error; the split
        is in the field's tooltip), and the render's time; a brush stroke or a turn of the camera renders
        too, but that rate is not a drag's: "idle"."""
        dragging = time.perf_counter() - self.dragging.frame_shown_at <= 1.0
        fps = self.view.display_fps() if dragging else 0.0
        parts = [f"{fps:.0f} fps" if fps > 0 else "idle"]
        d = self.dragging
        if d.engine_ms > 0:
            parts.append(f"frame {d.thread_ms:.0f} ms")
            self.time_label.setToolTip(
                f"The latest drag frame: {d.thread_ms:.1f} ms on the frame thread, of which the engine's solve "
                f"{d.engine_ms:.1f} ms and the moving region's points, normals and edge error "
                f"{max(d.thread_ms - d.engine_ms, 0.0):.1f} ms; the render runs beside it")
        if self.view.render_seconds > 0:
            parts.append(f"render {self.view.render_seconds * 1e3:.0f} ms")
        return " · ".join(parts)
