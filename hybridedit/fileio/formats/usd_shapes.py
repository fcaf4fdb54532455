"""Poses as USD blend shapes (.usda, .usdc, .usd) through ``usd-core`` (the optional ``usd`` extra).

The stage (up axis Y, 1 metre a unit, as glTF's) holds one ``SkelRoot``, its default prim, named
after the file; in it:

- ``Mesh``: the rest mesh with the document's polygons (``faceVertexCounts``, ``faceVertexIndices``),
  vertex normals (recomputed from the rest surface), texture coordinates (``primvars:st``,
  face-varying and indexed, as OBJ's ``vt``) and vertex colours (``primvars:displayColor``, made
  linear: with no ``colorSpace`` authored, USD reads colours as linear Rec.709 (:mod:`.srgb`); and
  ``primvars:displayOpacity``, the alpha as it is, where one is not opaque), with
  ``subdivisionScheme = "none"`` so that clients draw the polygons as they are;
- a ``BlendShape`` under the mesh per pose: ``offsets`` (float32 point deltas) and ``normalOffsets``,
  with ``pointIndices`` when the pose moves a part of the mesh (only that part's rows are stored);
- ``Skel``: a ``Skeleton`` of one joint at the origin (blend shapes are driven through a skeleton; the
  mesh is bound to the joint rigidly with weight 1, so it does not move it) whose animation source
  ``Skel/Anim`` names the blend shapes and gives every weight 0: the file opens at rest.

The mesh's ``SkelBindingAPI`` names the blend shapes (``skel:blendShapes``) and points at them
(``skel:blendShapeTargets``). A pose's prim and token are its name made a valid identifier (made
unique); the name as given is the prim's display name.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from ..document import Document
from ...core.normals import vertex_normals
from .common import _Bad
from .srgb import srgb_to_linear

__all__ = ["MISSING", "identifiers", "write"]

MISSING = "writing USD needs usd-core, which is not installed: pip install 'hybridedit[usd]'"


def _pxr():
    """The ``pxr`` modules this writer uses; _Bad (:data:`MISSING`) without usd-core."""
    try:
        from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdSkel, Vt
    except ImportError:
        raise _Bad(MISSING) from None
    return Gf, Sdf, Tf, Usd, UsdGeom, UsdSkel, Vt


def identifiers(names: list[str]) -> list[str]:
    """Each name made a valid, unique USD identifier ("arm up" -> "arm_up"; a second one "arm_up_2")."""
    _, _, Tf, *_ = _pxr()
    taken: set[str] = set()
    out = []
    for name in names:
        base = Tf.MakeValidIdentifier(name) if name else "pose"
        ident, k = base, 2
        while ident in taken:
            ident, k = f"{base}_{k}", k + 1
        taken.add(ident)
        out.append(ident)
    return out


def write(doc: Document, poses: np.ndarray, names: list[str], *, normals: bool = True,
          sparse: bool = True, suffix: str = ".usda") -> bytes:
    """The USD file (``suffix``: .usda text, .usdc or .usd binary crate) of ``doc``'s mesh at rest with
    a blend shape per pose.

    Parameters
    ----------
    doc : Document
        Its ``mesh.vertices`` (n, 3) are the rest.
    poses : (k, n, 3) float64
        Each pose's positions (finite; checked by the caller).
    names : list of k str
    normals : bool
        Write ``normalOffsets`` too.
    sparse : bool
        Store only the moved rows (``pointIndices``) of a pose that moves less than 3/4 of the mesh.
    suffix : {".usda", ".usdc", ".usd"}
    """
    Gf, Sdf, Tf, Usd, UsdGeom, UsdSkel, Vt = _pxr()
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root_name = Tf.MakeValidIdentifier(Path(doc.mesh.name or "mesh").stem or "mesh")
    root = UsdSkel.Root.Define(stage, Sdf.Path("/" + root_name))
    stage.SetDefaultPrim(root.GetPrim())
    mesh = _rest_mesh(stage, root.GetPath().AppendChild("Mesh"), doc)
    rest = doc.mesh.vertices
    rest32 = rest.astype(np.float32).astype(np.float64)  # (what ``points`` holds)
    faces = doc.mesh.faces
    rest_normals = vertex_normals(rest, faces).astype(np.float32).astype(np.float64)
    tokens = identifiers(names)
    paths = []
    for P, token, name in zip(poses, tokens, names):
        shape = UsdSkel.BlendShape.Define(stage, mesh.GetPath().AppendChild(token))
        if token != name:
            shape.GetPrim().SetDisplayName(name)
        moved = np.any(P != rest, axis=1)
        changed = moved.copy()
        if normals:
            changed[faces[moved[faces].any(axis=1)].ravel()] = True  # the normals a moved vertex touches
        rows = np.flatnonzero(changed) if sparse and changed.sum() < 0.75 * len(rest) else np.arange(len(rest))
        offsets = np.where(moved[rows, None], P[rows] - rest32[rows], 0.0)
        shape.CreateOffsetsAttr(Vt.Vec3fArray.FromNumpy(offsets.astype(np.float32)))
        if len(rows) < len(rest):
            shape.CreatePointIndicesAttr(Vt.IntArray.FromNumpy(rows.astype(np.int32)))
        if normals:
            change = np.where(changed[rows, None], vertex_normals(P, faces)[rows] - rest_normals[rows], 0.0)
            shape.CreateNormalOffsetsAttr(Vt.Vec3fArray.FromNumpy(change.astype(np.float32)))
        paths.append(shape.GetPath())
    skel = _skeleton(stage, root.GetPath().AppendChild("Skel"), tokens)
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skel.GetPath()])
    binding.CreateBlendShapesAttr(Vt.TokenArray(tokens))
    binding.CreateBlendShapeTargetsRel().SetTargets(paths)
    # bound rigidly to the one joint (identity), with weight 1: skinning leaves the mesh where it is
    binding.CreateJointIndicesPrimvar(True, 1).Set(Vt.IntArray([0]))
    binding.CreateJointWeightsPrimvar(True, 1).Set(Vt.FloatArray([1.0]))
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1.0))
    return _layer_bytes(stage, suffix)


def _rest_mesh(stage, path, doc: Document):
    """The ``Mesh`` prim at ``path``: the document's rest polygons, normals, UVs and colours."""
    _, Sdf, _, _, UsdGeom, _, Vt = _pxr()
    V = doc.mesh.vertices
    counts, flat = doc.polygon_lists()
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(V.astype(np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(counts.astype(np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(flat.astype(np.int32)))
    mesh.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(np.stack([V.min(axis=0), V.max(axis=0)]).astype(np.float32)))
    mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(vertex_normals(V, doc.mesh.faces).astype(np.float32)))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    primvars = UsdGeom.PrimvarsAPI(mesh)
    tex = doc.textures()
    if tex is not None and tex.uv is not None and tex.corner_uv is not None:
        uv, corner = tex.uv, tex.corner_uv
        if np.any(corner < 0):  # corners without coordinates: (0, 0), as the other writers give them
            uv, corner = np.vstack([uv, [0.0, 0.0]]), np.where(corner < 0, len(uv), corner)
        st = primvars.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
        st.Set(Vt.Vec2fArray.FromNumpy(uv.astype(np.float32)))
        st.SetIndices(Vt.IntArray.FromNumpy(corner.astype(np.int32)))
    if doc.colors is not None:
        rgba = srgb_to_linear(doc.colors).astype(np.float32)  # (no colorSpace authored: linear Rec.709)
        mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(Vt.Vec3fArray.FromNumpy(rgba[:, :3]))
        if np.any(rgba[:, 3] < 1):
            mesh.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.vertex).Set(Vt.FloatArray.FromNumpy(rgba[:, 3]))
    return mesh


def _skeleton(stage, path, tokens: list[str]):
    """A skeleton of one joint at the origin at ``path``, its animation (``Anim``) all blend shape
    weights 0."""
    Gf, _, _, _, _, UsdSkel, Vt = _pxr()
    skel = UsdSkel.Skeleton.Define(stage, path)
    skel.CreateJointsAttr(Vt.TokenArray(["root"]))
    skel.CreateBindTransformsAttr(Vt.Matrix4dArray([Gf.Matrix4d(1.0)]))
    skel.CreateRestTransformsAttr(Vt.Matrix4dArray([Gf.Matrix4d(1.0)]))
    anim = UsdSkel.Animation.Define(stage, path.AppendChild("Anim"))
    anim.CreateBlendShapesAttr(Vt.TokenArray(tokens))
    anim.CreateBlendShapeWeightsAttr(Vt.FloatArray([0.0] * len(tokens)))
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    return skel


def _layer_bytes(stage, suffix: str) -> bytes:
    """The stage's root layer as a file of ``suffix`` (.usd: the binary crate, USD's default for it)."""
    with tempfile.TemporaryDirectory(prefix="hybridedit-usd-") as folder:
        tmp = os.path.join(folder, "poses" + suffix)
        if not stage.GetRootLayer().Export(tmp, args={"format": "usda" if suffix == ".usda" else "usdc"}):
            raise _Bad("usd-core could not write the layer")
        return Path(tmp).read_bytes()
