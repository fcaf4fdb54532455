"""hybridedit: interactive ARAP editing of large meshes through a QEM cage.

After Borosán, Howard, Zhang and Nealen, "Hybrid Mesh Editing" (Eurographics 2010).
"""

import os as _os
import sys as _sys


def _numba_cache_where_writable() -> None:
    """Compiled kernels are cached next to the code; where the user cannot write there (an
    installation owned by root), point numba at the user cache folder instead, so that they
    compile once, not at every run. Must run before numba is imported by the modules below."""
    if _os.environ.get("NUMBA_CACHE_DIR"):
        return
    here = _os.path.dirname(_os.path.abspath(__file__))
    pycache = _os.path.join(here, "__pycache__")
    if _os.access(pycache if _os.path.isdir(pycache) else here, _os.W_OK):
        return
    from .bindcache import default_cache_dir

    folder = str(default_cache_dir() / "numba")
    _os.environ["NUMBA_CACHE_DIR"] = folder
    if "numba" in _sys.modules:  # imported before us: numba read its settings already
        _sys.modules["numba"].config.CACHE_DIR = folder


_numba_cache_where_writable()

from .arap import ARAPSolver  # noqa: E402
from .binding import bind
from .cage import build_cage
from .editfile import Edit, EditFileError, load_edit, save_edit
from .editor import HybridEditor, SelectionError
from .io import MeshFileError, read_mesh, write_mesh
from .mesh import Mesh, MeshError, rrms_edge_error
from .mvc import mean_value_coordinates
from .propagate import propagate
from .rig import Rig, build_rig
from .transforms import apply_transform, rigid_transform

__version__ = "0.1.0"

__all__ = [
    "ARAPSolver",
    "Edit",
    "EditFileError",
    "HybridEditor",
    "Mesh",
    "MeshError",
    "MeshFileError",
    "Rig",
    "SelectionError",
    "apply_transform",
    "bind",
    "build_cage",
    "build_rig",
    "load_edit",
    "mean_value_coordinates",
    "propagate",
    "read_mesh",
    "rigid_transform",
    "rrms_edge_error",
    "save_edit",
    "write_mesh",
]
