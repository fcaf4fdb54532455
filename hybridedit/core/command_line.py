"""What the two commands share (``hybridedit`` and ``hybridedit batch``): the error for arguments
a user can fix, the ``--cage`` argument's type, and an exception said in one line.

Both :mod:`hybridedit.cli` and :mod:`hybridedit.batching.command` take them from here, below both,
so that the batch command does not reach up into the CLI it is a part of.
"""

from __future__ import annotations

import argparse

from ..defaults import parse_cage_size as _parse_cage_size

__all__ = ["CLIError", "parse_cage_size", "one_line"]


class CLIError(Exception):
    """A problem the user can fix; printed as one line, exit status 2."""


def parse_cage_size(text: str) -> int | float:
    """'2000' -> 2000 vertices, '0.05' or '5%' -> a fraction of the shape's vertices
    (:func:`hybridedit.defaults.parse_cage_size`, as argparse takes it: an
    ``argparse.ArgumentTypeError`` for anything else)."""
    try:
        return _parse_cage_size(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def one_line(e: BaseException) -> str:
    """An exception's message on one line (its whitespace runs made single spaces), or its type's
    name when it has none.

    Examples
    --------
    >>> one_line(ValueError("a\\n  b")), one_line(KeyboardInterrupt())
    ('a b', 'KeyboardInterrupt')
    """
    text = " ".join(str(e).split())
    return text or type(e).__name__
