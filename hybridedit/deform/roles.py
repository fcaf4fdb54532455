"""Vertex roles: the one code for what a vertex does in an edit, shared by the engine and the window.

A role is a small integer, the same for shape and cage vertices::

    FIXED = -1      stays where it is
    FREE  =  0      moves as the ARAP solve decides (inside the region of interest)
    g + 1           follows handle group g's transform (g = 0, 1, ...)

:attr:`hybridedit.HybridEditor.vertex_roles` and ``cage_roles`` report roles in this code, and
``shape_roles`` / ``preview_roles`` take them.

Examples
--------
>>> from hybridedit.deform import roles
>>> roles.handle(0), roles.group(roles.handle(2)), roles.is_handle(roles.FREE)
(1, 2, False)
"""

from __future__ import annotations

import numpy as np

FIXED = -1
FREE = 0
FIRST_HANDLE = 1  # handle group 0


def handle(group):
    """The role of handle group ``group`` (an int or an int array): ``group + 1``."""
    return group + FIRST_HANDLE


def group(role):
    """The handle group of a handle ``role`` (an int or an int array): ``role - 1``."""
    return role - FIRST_HANDLE


def is_handle(role):
    """Whether ``role`` (an int or an int array) is a handle group's."""
    return np.asarray(role) >= FIRST_HANDLE if np.ndim(role) else bool(role >= FIRST_HANDLE)
