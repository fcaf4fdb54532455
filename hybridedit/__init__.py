"""hybridedit: interactive ARAP editing of large meshes through a QEM cage.

After Borosán, Howard, Zhang and Nealen, "Hybrid Mesh Editing" (Eurographics 2010).

The names below are imported on first use, so that ``import hybridedit`` (and the
``hybridedit`` command, which can refuse a bad output path before any work) starts
at once; the compiled engine loads when it is first needed.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_WHERE = {
    "ARAPSolver": "arap",
    "Document": "document",
    "Edit": "editfile",
    "EditFileError": "editfile",
    "HybridEditor": "editor",
    "Mesh": "mesh",
    "MeshError": "mesh",
    "MeshFileError": "io",
    "Rig": "rig",
    "SelectionError": "selection",
    "apply_transform": "transforms",
    "bind": "binding",
    "build_cage": "cage",
    "build_rig": "rig",
    "load_edit": "editfile",
    "mean_value_coordinates": "mvc",
    "propagate": "propagate",
    "read_document": "io",
    "read_mesh": "io",
    "rigid_transform": "transforms",
    "rrms_edge_error": "mesh",
    "save_edit": "editfile",
    "write_document": "io",
    "write_mesh": "io",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'hybridedit' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(list(globals()) + __all__)
