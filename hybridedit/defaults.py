"""Settings that several parts of hybridedit share, each written once, and the one rule for a cage
size (no Qt, no numba: cheap to import).
"""

from __future__ import annotations

import numbers

#: The cage size a shape gets unless told otherwise: this fraction of its (own, welded) vertices.
CAGE_SIZE = 0.05
#: Fraction of each binding row's coordinate magnitude the truncation drops (the paper's 3%).
TRUNCATION = 0.03
#: ARAP iterations a frame (a drag call) runs.
ITERATIONS = 2
#: Frames the settle after a drag runs, and ``hybridedit deform`` for a step that records none.
SETTLE_FRAMES = 30
#: Most iterations a full-resolution polish runs (the window's polish on release, ``deform --polish``).
POLISH_MAX_ITERATIONS = 200
#: A polish has converged when an iteration moves no vertex by more than this fraction of the diagonal.
POLISH_TOLERANCE = 1e-6
#: A converge (the cage's ARAP to its fixed point) stops when its bound on the distance to the fixed
#: point is at most this fraction of the diagonal.
CONVERGE_TOLERANCE = 1e-6
#: Most iterations a converge runs (a run stopped there says it did not converge).
CONVERGE_MAX_ITERATIONS = 10000


#: The cage sizes a user may give, in words (the messages that refuse one say them).
CAGE_SIZE_FORMS = "a vertex count (2000), a fraction of the shape's vertices (0.05) or a percentage ('5%')"


def check_cage_size(size) -> int | float:
    """A cage size as the engine takes it: an int vertex count (at least 4), a float fraction in
    (0, 1] of the shape's vertices, or either written as text as the command line takes it
    (:func:`parse_cage_size`: a config file's or a form's "0.05", "5%", "2000"); anything else is a
    ValueError naming ``cage_size`` and what is accepted.

    Parameters
    ----------
    size : int, float or str

    Returns
    -------
    int or float: an int for a vertex count, a float for a fraction

    Examples
    --------
    >>> check_cage_size(2000), check_cage_size(0.05), check_cage_size("5%"), check_cage_size(" 2000 ")
    (2000, 0.05, 0.05, 2000)
    """
    if isinstance(size, str):
        try:
            return parse_cage_size(size)
        except ValueError:
            raise ValueError(f"cage_size must be {CAGE_SIZE_FORMS}, got {size!r}") from None
    if isinstance(size, bool) or not isinstance(size, numbers.Real):
        raise ValueError(f"cage_size must be {CAGE_SIZE_FORMS}, got {size!r}")
    if isinstance(size, numbers.Integral):
        if int(size) < 4:
            raise ValueError(f"a cage needs at least 4 vertices, asked for {int(size)}")
        return int(size)
    if not (0.0 < float(size) <= 1.0):
        raise ValueError(f"cage fraction must be in (0, 1], got {size!r}")
    return float(size)


def parse_cage_size(text: str) -> int | float:
    """A cage size written by a user: '2000' (vertices), '0.05' or '5%' (a fraction), checked by
    :func:`check_cage_size`; a ValueError saying what was expected otherwise.

    Examples
    --------
    >>> parse_cage_size("5%"), parse_cage_size("2000")
    (0.05, 2000)
    """
    s = str(text).strip()
    try:
        if s.endswith("%"):
            value: int | float = float(s[:-1]) / 100.0
        elif s.isdigit():
            value = int(s)
        else:
            value = float(s)
    except ValueError:
        raise ValueError(f"cage size must be {CAGE_SIZE_FORMS}, got {text!r}") from None
    return check_cage_size(value)
