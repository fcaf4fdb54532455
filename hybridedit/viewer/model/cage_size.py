"""The rule that fits a cage size to a shape: a fraction of its vertices, or a vertex count.

The rule (:func:`fit_cage_size`): a cage is a coarse stand-in for its shape, and what it costs grows
with its size (the binding with shape vertices x cage vertices; an open surface's cage is a shell of
twice its vertices). A vertex count above :data:`MAX_SHARE` (half) of the shape's vertices is not a
cage for that shape (a count left from a bigger shape, or a slip): the build uses
:data:`DEFAULT_SIZE` (5 %) instead, the box shows it, and the status bar says so before the cage is
built. A percentage is the user's choice for any shape, and is used as it is.
"""

from __future__ import annotations

import numpy as np

from ...defaults import CAGE_SIZE

DEFAULT_SIZE = CAGE_SIZE
"""The cage size a shape starts from: 5 % of its vertices."""

MAX_SHARE = 0.5
"""The largest vertex count a shape takes, as a share of its vertices (above it: :data:`DEFAULT_SIZE`)."""


def is_count(size: int | float) -> bool:
    """``size`` is a vertex count (an int), not a fraction."""
    return isinstance(size, (int, np.integer)) and not isinstance(size, (bool, np.bool_))


def fit_cage_size(size: int | float, n_vertices: int | None) -> tuple[int | float, str | None]:
    """The cage size a shape of ``n_vertices`` vertices is built at, and why it is not ``size``.

    Returns
    -------
    size : ``size`` itself, or :data:`DEFAULT_SIZE` for a vertex count above :data:`MAX_SHARE` of the shape.
    note : a sentence naming the size asked, the shape's size and the size used; None when ``size`` is used.

    Examples
    --------
    >>> fit_cage_size(9_999_999, 32_000)
    (0.05, "a cage of 9,999,999 vertices is more than half this shape's 32,000 vertices: using 5% (about 1,600)")
    >>> fit_cage_size(2000, 32_000), fit_cage_size(0.5, 32_000)
    ((2000, None), (0.5, None))
    """
    if not is_count(size) or not n_vertices or int(size) <= MAX_SHARE * n_vertices:
        return size, None
    used = DEFAULT_SIZE
    return used, (f"a cage of {int(size):,} vertices is more than half this shape's {int(n_vertices):,} vertices: "
                  f"using {used * 100:g}% (about {int(round(used * n_vertices)):,})")
