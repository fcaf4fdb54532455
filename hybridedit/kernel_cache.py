"""Where numba caches the compiled kernels: a folder per version of the kernel sources.

numba checks a cached kernel against its own source file only. A kernel that inlines or calls a
kernel of another file (the core helpers the binding kernels inline, the intrinsics of
:mod:`hybridedit.binding.lane_ir`) kept its old compiled code after that other file changed. So
``import hybridedit`` points numba (``NUMBA_CACHE_DIR``) at a folder named by
:func:`sources_stamp`, a digest of every file that defines a kernel: a change to any of them
starts an empty folder, and this installation's older folders are removed. A constant a kernel
reads is compiled into it, so it must live in a kernel file too.

The folders are kept in the package's own ``__pycache__`` (one checkout's kernels, removed with
it), or in the user cache folder where the package cannot be written (an installation owned by
root). A ``NUMBA_CACHE_DIR`` the user set is left alone (and with it, clearing a stale cache).

This module must stay cheap to import: it runs at ``import hybridedit``, before numba loads.
"""

from __future__ import annotations

import hashlib
import os
import re
import sys
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent

#: a decorator that makes a kernel (numba's, hand-written intrinsics, serial / parallel twins)
_KERNEL_DECORATOR = re.compile(rb"@(?:numba\.)?(?:njit|jit|intrinsic|twins)\b")

#: the folder this module chose, also in the environment: a child process that inherits
#: ``NUMBA_CACHE_DIR`` equal to it (set by the package, not the user) chooses its own
CHOSEN = "_HYBRIDEDIT_KERNEL_FOLDER"


def kernel_files(package_dir: Path = PACKAGE_DIR) -> list[Path]:
    """The package's source files that define numba kernels, sorted."""
    return [package_dir / name for name, _ in _kernel_sources(package_dir)]


def sources_stamp(package_dir: Path = PACKAGE_DIR) -> str:
    """A digest of every kernel source file (:func:`kernel_files`): their paths in the package
    and their bytes."""
    h = hashlib.sha256()
    for name, text in _kernel_sources(package_dir):
        h.update(name.encode() + b"\0" + text + b"\0")
    return h.hexdigest()[:16]


def _kernel_sources(package_dir: Path) -> list[tuple[str, bytes]]:
    """(path in the package, bytes) of each kernel source file, sorted by path."""
    found = []
    for folder, dirs, files in os.walk(package_dir):
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        for name in files:
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                try:
                    with open(path, "rb") as f:
                        text = f.read()
                except OSError:
                    continue
                if _defines_kernels(text):
                    found.append((Path(path).relative_to(package_dir).as_posix(), text))
    return sorted(found)


def _defines_kernels(text: bytes) -> bool:
    """A kernel decorator starts a line of ``text`` (a pattern led by ``@`` scans fast; one led
    by ``^`` in multiline mode took 8 ms over the package)."""
    for m in _KERNEL_DECORATOR.finditer(text):
        if not text[text.rfind(b"\n", 0, m.start()) + 1:m.start()].strip(b" \t"):
            return True
    return False


def cache_root(package_dir: Path = PACKAGE_DIR) -> Path:
    """The folder that holds this installation's kernel folders: ``__pycache__/kernels`` in the
    package, else (a package the user cannot write) one of its own in the user cache folder."""
    pycache = package_dir / "__pycache__"
    if os.access(pycache if pycache.is_dir() else package_dir, os.W_OK):
        return pycache / "kernels"
    from .core.cache_dir import default_cache_dir

    place = hashlib.sha256(str(package_dir).encode()).hexdigest()[:12]
    return default_cache_dir() / "kernels" / place


def use_folder_of_these_sources() -> None:
    """Point numba at the kernel folder of the current sources (unless the user chose a
    ``NUMBA_CACHE_DIR``); when that folder is new, remove the installation's older ones. Runs
    before numba loads; if it loaded first, its setting is changed too (numba reads it when a
    kernel is defined)."""
    chosen = os.environ.get("NUMBA_CACHE_DIR")
    if chosen and chosen != os.environ.get(CHOSEN):
        return
    root = cache_root()
    folder = root / sources_stamp()
    os.environ["NUMBA_CACHE_DIR"] = os.environ[CHOSEN] = str(folder)
    if "numba" in sys.modules:
        sys.modules["numba"].config.CACHE_DIR = str(folder)
    if not folder.is_dir():
        prune(root, keep=folder.name)
        if root == PACKAGE_DIR / "__pycache__" / "kernels":
            remove_beside_the_sources()
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError:
            pass  # (numba then finds a folder of its own)


def prune(root: Path, keep: str) -> None:
    """Remove the kernel folders in ``root`` but ``keep`` (a process still running older code
    compiles what it lacks again)."""
    try:
        old = [e.path for e in os.scandir(root) if e.is_dir() and e.name != keep]
    except OSError:
        return
    if old:
        import shutil

        for path in old:
            shutil.rmtree(path, ignore_errors=True)


def remove_beside_the_sources() -> None:
    """Remove the kernels numba cached beside the sources (``*/__pycache__/*.nbi``, ``*.nbc``)
    before there were kernel folders."""
    for folder, dirs, files in os.walk(PACKAGE_DIR):
        if os.path.basename(folder) == "__pycache__":
            dirs[:] = []
            for name in files:
                if name.endswith((".nbi", ".nbc")):
                    try:
                        os.unlink(os.path.join(folder, name))
                    except OSError:
                        pass
