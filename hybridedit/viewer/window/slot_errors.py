"""A slot's unexpected error shown to the user in a message box, not as a traceback."""

from __future__ import annotations

import functools
from typing import Callable


def guarded(method: Callable) -> Callable:
    """Run a slot of one of the window's collaborators; an unexpected error goes to the window's
    status bar (``self.w.status.show_error``: a message box and the message log) instead of a
    traceback, and the slot returns None."""

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        try:
            return method(self, *args, **kwargs)
        except Exception as e:  # noqa: BLE001
            self.w.status.show_error("Unexpected error", f"{e.__class__.__name__}: {e}")
            return None

    return wrapper
