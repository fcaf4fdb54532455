"""hybridedit: interactive ARAP editing of large meshes through a QEM cage.

After Borosán, Howard, Zhang and Nealen, "Hybrid Mesh Editing" (Eurographics 2010).

The names below are imported on first use, so that ``import hybridedit`` (and the
``hybridedit`` command, which can refuse a bad output path before any work) starts
at once; the compiled engine loads when it is first needed.
"""

from __future__ import annotations

import importlib
import importlib.util
import os as _os

__version__ = "0.1.0"

from . import kernel_cache as _kernel_cache  # noqa: E402 -- (before numba loads; cheap: no numpy)

_kernel_cache.use_folder_of_these_sources()  # (compiled kernels cached per version of their sources)

# OpenMP threads (numba's parallel kernels, CHOLMOD) wait for work asleep rather than spinning
# (GNU OpenMP spins up to ~0.3 s by default): a spinning worker holds a core that the frame's other
# thread, or the user's other programs, need (hybridedit.core.parallel). Read when the OpenMP
# runtime loads, which is after this line; a user's own setting wins.
_os.environ.setdefault("OMP_WAIT_POLICY", "passive")

#: each public name and the module it lives in. The package sits on floors, each importing only from
#: its own or lower ones: defaults < core < fileio < cage < binding < deform < batching < the top
#: (cli, viewer, warmup, and this table, which names every floor); tests/test_layers.py holds them
_WHERE = {
    "ARAPSolver": "deform.arap",
    "Document": "fileio.document",
    "Edit": "fileio.editfile",
    "EditFileError": "fileio.editfile",
    "HandleEdit": "fileio.editfile",
    "HybridEditor": "deform.editor",
    "Mesh": "core.mesh",
    "MeshError": "core.mesh",
    "MeshFileError": "fileio.meshfiles",
    "Rig": "binding.rig",
    "SelectionError": "deform.selection",
    "apply_transform": "core.transforms",
    "backend_description": "core.linsolve",
    "batch": "batching.api",
    "bind": "binding.bind",
    "build_cage": "cage.build",
    "build_rig": "binding.rig",
    "load_edit": "fileio.editfile",
    "mean_value_coordinates": "binding.mvc",
    "propagate_positions": "deform.propagate",
    "read_document": "fileio.meshfiles",
    "read_mesh": "fileio.meshfiles",
    "rigid_transform": "core.transforms",
    "rrms_edge_error": "core.mesh",
    "save_edit": "fileio.editfile",
    "save_poses": "fileio.poses",
    "widget": "web.notebook",
    "write_document": "fileio.meshfiles",
    "write_mesh": "fileio.meshfiles",
}

#: exported under another name than in their module: a package attribute named like a
#: submodule would be that function in a fresh interpreter but the submodule once anything
#: imported it (the import system binds ``hybridedit.deform.propagate`` to the module)
_RENAMED = {"propagate_positions": "propagate"}

from .defaults import CAGE_SIZE as _CAGE_SIZE  # noqa: E402 -- (a plain module: cheap to import here)

__all__ = sorted(_WHERE)  # (not ``open``: ``from hybridedit import *`` must not hide the builtin)


def open(path, cage_size: int | float = _CAGE_SIZE, **options):  # noqa: A001  (he.open, as io.open)
    """Open a mesh file for editing: ``HybridEditor.from_file(path, cage_size, **options)``.

    The editor keeps everything the file holds (texture coordinates, polygons,
    materials, colours), and ``editor.save(path)`` writes it all back with the
    edited positions. Options: ``cache``, ``truncation``, ``progress`` (building),
    ``weights``, ``iterations``, ``propagation`` (the editor).
    """
    from .deform.editor import HybridEditor

    return HybridEditor.from_file(path, cage_size, **options)


def __getattr__(name: str):
    module = _WHERE.get(name)
    if module is None:
        if not name.startswith("_") and importlib.util.find_spec(f"{__name__}.{name}") is not None:
            return importlib.import_module(f".{name}", __name__)  # a submodule (the import binds it here)
        raise AttributeError(f"module 'hybridedit' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), _RENAMED.get(name, name))
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(list(globals()) + __all__)
