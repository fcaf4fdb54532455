"""hybridedit: interactive ARAP editing of large meshes through a QEM cage.

After Borosán, Howard, Zhang and Nealen, "Hybrid Mesh Editing" (Eurographics 2010).
"""

from .arap import ARAPSolver
from .binding import bind
from .cage import build_cage
from .editfile import Edit, EditFileError, load_edit, save_edit
from .editor import HybridEditor, SelectionError
from .document import Document
from .io import MeshFileError, read_document, read_mesh, write_document, write_mesh
from .mesh import Mesh, MeshError, rrms_edge_error
from .mvc import mean_value_coordinates
from .propagate import propagate
from .rig import Rig, build_rig
from .transforms import apply_transform, rigid_transform

__version__ = "0.1.0"

__all__ = [
    "ARAPSolver",
    "Document",
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
    "read_document",
    "read_mesh",
    "rigid_transform",
    "rrms_edge_error",
    "save_edit",
    "write_document",
    "write_mesh",
]
