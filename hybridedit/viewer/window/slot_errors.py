"""A slot's unexpected error shown to the user in a message box, not as a traceback, and written down
in a crash report (:mod:`~..model.crash_reports`)."""

from __future__ import annotations

import functools
from typing import Callable

from ..model.crash_reports import describe, failure_message, is_crash, write_crash_report


def guarded(method: Callable) -> Callable:
    """Run a slot of one of the window's collaborators; an error goes to the window's status bar
    (``self.w.status.show_error``: a message box and the message log) instead of a traceback, and the
    slot returns None. An unexpected one (:func:`~..model.crash_reports.is_crash`) is written to a crash
    report first, whose path the message names."""

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        try:
            return method(self, *args, **kwargs)
        except Exception as e:  # noqa: BLE001
            if not is_crash(e):
                self.w.status.show_error("Unexpected error", describe(e))
                return None
            report = write_crash_report(e, context=f"{type(self).__name__}.{method.__name__}")
            what = f"{method.__name__.replace('_', ' ').strip().capitalize()} failed"
            self.w.status.show_error("Unexpected error", failure_message(what, e, report))
            return None

    return wrapper
