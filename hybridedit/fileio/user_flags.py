"""Things the user has done once and need not be offered again, remembered in the user cache folder.

A flag is a name that is set once (the window's first-steps hint dismissed, say) and stays set. The
flags are kept in one small JSON file of the cache folder
(:func:`hybridedit.core.cache_dir.default_cache_dir`), next to the remembered up axes, written
atomically; a folder that cannot be read or written leaves every flag unset and costs one False.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..core.cache_dir import default_cache_dir
from .atomic import atomic_write

__all__ = ["FILE_NAME", "flag_set", "set_flag"]

FILE_NAME = "user-flags.json"
"""The file in the cache folder that holds the flags set (a JSON list of names)."""


def _read(folder: Path) -> set[str]:
    try:
        data = json.loads((folder / FILE_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return set()
    return {n for n in data if isinstance(n, str)} if isinstance(data, list) else set()


def flag_set(name: str, *, folder: Path | None = None) -> bool:
    """Whether the flag ``name`` was set (:func:`set_flag`), in ``folder`` (default: the cache folder)."""
    return name in _read(folder or default_cache_dir())


def set_flag(name: str, *, folder: Path | None = None) -> bool:
    """Set the flag ``name`` for good; False when the cache folder cannot be written."""
    folder = folder or default_cache_dir()
    names = _read(folder) | {name}
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with atomic_write(folder / FILE_NAME, "w") as fh:
            json.dump(sorted(names), fh, indent=0)
    except OSError:
        return False
    return True
