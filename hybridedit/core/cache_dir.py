"""The user cache folder: where the binding cache, the remembered up axes, the compiled kernels'
stamp and (for an installation the user cannot write) numba's cache live.

It sits in core, the lowest floor, because every floor keeps something there and the package's
``__init__`` asks for it before numba loads: it imports nothing of hybridedit and no numpy.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["default_cache_dir"]


def default_cache_dir() -> Path:
    """$HYBRIDEDIT_CACHE_DIR, else the user cache folder (e.g. ~/.cache/hybridedit).

    Returns
    -------
    Path
        The folder (not created here: each user creates what it writes).
    """
    env = os.environ.get("HYBRIDEDIT_CACHE_DIR")
    if env:
        return Path(env)
    from platformdirs import user_cache_dir

    return Path(user_cache_dir("hybridedit", appauthor=False))
