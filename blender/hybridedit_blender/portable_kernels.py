"""Kernels compiled for any x86-64 CPU, shipped in the Linux zip: the first Bind after installing
loads them instead of waiting minutes for the background compile.

numba keys a cached kernel by the CPU's name and features and files it under a folder named by the
absolute path of its source folder. The zip's kernels were compiled (by ``build_extension.py``)
for the ``generic`` CPU, which every x86-64 machine runs, and are filed by source folder relative
to the package (``kernels/hybridedit/binding/...``). :func:`choose` copies them once into a folder
of the user's, under the names numba derives from where hybridedit is installed here, and points
this Blender's numba at them, with its CPU set to ``generic`` for the session. numba checks each
kernel against its source's content: a kernel whose source differs is compiled as before.

They serve the sessions until the background compile (:mod:`.kernels`) has compiled the kernels
for this machine's CPU: from the next start on, Blender uses those (the portable ones run the
cage's rotation step at about half the speed, the rest of a frame at about the same).
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import platform
import shutil
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
#: the kernels' folder in the extension, and its description (written by build_extension.py)
FOLDER = os.path.join(HERE, "kernels")
INFO = "info.json"
#: the CPU they were compiled for (numba's NUMBA_CPU_NAME: every x86-64 CPU runs its code)
CPU = "generic"

#: the folder of portable kernels this Blender's numba uses (None: the kernels compiled here)
IN_USE: str | None = None


def numba_folder_name(source_dir: str) -> str:
    """The folder numba files a source folder's kernels under, inside ``NUMBA_CACHE_DIR``
    (numba's ``UserProvidedCacheLocator``: the folder's name and the SHA-1 of its absolute path)."""
    path = os.path.abspath(source_dir)
    return f"{os.path.basename(path)}_{hashlib.sha1(path.encode()).hexdigest()}"


def info(folder: str = FOLDER) -> dict | None:
    """The shipped kernels' description (``platform``, ``machine``, ``python``, ``numba``, ``numpy``,
    ``cpu``, ``id``), or None when there are none."""
    try:
        with open(os.path.join(folder, INFO), encoding="utf-8") as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def why_not(meta: dict | None) -> str | None:
    """Why this Blender cannot use kernels described by ``meta`` (None: it can)."""
    if meta is None:
        return "none are shipped for this platform"
    here = {"platform": sys.platform, "machine": platform.machine().lower(),
            "python": f"{sys.version_info[0]}.{sys.version_info[1]}"}
    for key, value in here.items():
        if meta.get(key) != value:
            return f"they are for {key} {meta.get(key)}, this is {value}"
    try:
        from importlib.metadata import version

        numba, numpy = version("numba"), version("numpy")
    except Exception:  # noqa: BLE001 -- no metadata: nothing to match
        return "numba's or numpy's version is unknown"
    if meta.get("numba") != numba:
        return f"they are for numba {meta.get('numba')}, this is {numba}"
    if str(meta.get("numpy", "")).split(".")[0] != numpy.split(".")[0]:  # (numba types some calls by numpy's major)
        return f"they are for numpy {meta.get('numpy')}, this is {numpy}"
    if os.environ.get("NUMBA_CPU_NAME") or os.environ.get("NUMBA_CPU_FEATURES"):
        return "NUMBA_CPU_NAME or NUMBA_CPU_FEATURES is set"
    if "numba" in sys.modules:
        from numba.core.registry import cpu_target

        if "_toplevel_target_context" in vars(cpu_target):  # (its CPU is chosen once, at its first kernel)
            return "numba compiled a kernel in this Blender already"
    return None


def install(meta: dict, into: str, *, folder: str = FOLDER, package_dir: str | None = None) -> str:
    """Copy the shipped kernels into ``into/<id>``, each source folder's under numba's name for it
    where hybridedit is installed (``package_dir``, default: found without importing it); returns
    that folder. Done once: a folder complete from before is used as it is."""
    target = os.path.join(into, meta["id"])
    done = os.path.join(target, ".complete")
    if os.path.isfile(done):
        return target
    if package_dir is None:
        spec = importlib.util.find_spec("hybridedit")
        if spec is None or not spec.submodule_search_locations:
            raise OSError("hybridedit is not installed")
        package_dir = list(spec.submodule_search_locations)[0]
    tmp = f"{target}.{os.getpid()}.tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    source_root = os.path.join(folder, "hybridedit")
    for here, _dirs, files in os.walk(source_root):
        names = [n for n in files if n.endswith((".nbi", ".nbc"))]
        if not names:
            continue
        rel = os.path.relpath(here, source_root)
        source_dir = os.path.normpath(os.path.join(package_dir, rel))
        out = os.path.join(tmp, numba_folder_name(source_dir))
        os.makedirs(out, exist_ok=True)
        for n in names:
            shutil.copyfile(os.path.join(here, n), os.path.join(out, n))
    os.makedirs(tmp, exist_ok=True)
    with open(os.path.join(tmp, ".complete"), "w", encoding="utf-8") as f:
        f.write(f"portable kernels {meta['id']} for {package_dir}\n")
    shutil.rmtree(target, ignore_errors=True)
    os.replace(tmp, target)  # (a half-copied folder is never used)
    return target


def choose(into: str, *, native_ready: bool, folder: str = FOLDER) -> str | None:
    """At enabling, before the engine loads: use the shipped kernels when the kernels compiled for
    this CPU are not ready and this Blender can; returns their folder (``NUMBA_CACHE_DIR`` and the
    CPU are then set for this session) or None. Once the native ones are ready the copy goes."""
    global IN_USE
    if native_ready:
        shutil.rmtree(into, ignore_errors=True)
        return None
    meta = info(folder)
    if why_not(meta) is not None:
        return None
    try:
        path = install(meta, into, folder=folder)
    except OSError as e:
        print(f"Hybrid ARAP: the portable kernels could not be copied ({e}): the first Bind waits for the compile")
        return None
    for stale in os.listdir(into):  # (kernels of an earlier version of the extension)
        if stale != meta["id"]:
            shutil.rmtree(os.path.join(into, stale), ignore_errors=True)
    os.environ["NUMBA_CACHE_DIR"] = path
    os.environ["NUMBA_CPU_NAME"] = CPU
    if "numba" in sys.modules:
        config = sys.modules["numba"].config
        config.CACHE_DIR, config.CPU_NAME, config.CPU_FEATURES = path, CPU, ""
    IN_USE = path
    return path


def child_environment(env: dict[str, str]) -> dict[str, str]:
    """``env`` without the portable kernels' settings (a process that compiles for this CPU)."""
    if IN_USE is not None:
        env = {k: v for k, v in env.items() if k != "NUMBA_CPU_NAME"}
    return env
