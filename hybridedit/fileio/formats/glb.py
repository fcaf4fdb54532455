"""glTF binary (.glb) through ``pygltflib``: only positions and normals change.

Every triangle primitive of every mesh the scene places is read in world space
(node transforms applied); corners with equal world positions become one engine
vertex, so parts split at UV seams edit as one surface. Writing changes, in the
binary buffer, the POSITION of each moved vertex (back in its node's space) and
the NORMAL of each vertex a moved vertex touches; everything else (UVs,
materials, embedded textures, other primitives, extensions) is kept byte for
byte. A normal is recomputed over all corners that share its position and its
original direction, so normals stay smooth across UV seams and split at hard
edges. A mesh placed by several nodes is edited through its first one.

A document read from another format is written as a new .glb (pygltflib): one
triangle mesh with its normals, vertex colours, texture coordinates and
materials (base colour and its texture image, embedded), one primitive per
material. Reading one back, texture coordinates (v flipped back) and materials
are there for a conversion to OBJ or PLY.

``COLOR_0`` holds linear values, a document display (sRGB) ones: reading decodes
and a new .glb encodes them (:mod:`.srgb`); a file written back to itself keeps
its own ``COLOR_0`` bytes, as it keeps everything but positions and normals.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np
import pygltflib

from ..document import Document, Material, Texturing, moved_vertices
from ...core.normals import grouped_normals, vertex_normals
from .common import _Bad, fan_triangles, _mesh
from .glb_buffer import GltfBuffer
from .srgb import linear_to_srgb, srgb_to_linear

__all__ = ["GlbNative", "PlainGlb", "plain_glb", "read", "write"]

_TRIANGLES = 4


@dataclass
class _Slot:
    """One triangle primitive as placed in the scene."""

    position: int  # accessor index
    normal: int | None
    world: np.ndarray  # (4, 4)
    first: int  # first file vertex (over all slots) of this primitive
    mesh: int = -1  # its mesh and its place among the mesh's primitives
    primitive: int = -1


@dataclass(eq=False)
class GlbNative:
    gltf: pygltflib.GLTF2
    slots: list[_Slot]
    file_vertex: np.ndarray  # (k,) engine vertex of each file vertex
    rest: np.ndarray  # (n, 3) engine positions as read
    normal_group: np.ndarray  # (k,) normal group of each file vertex
    n_groups: int
    file_triangles: np.ndarray  # (m, 3) file vertex indices of the engine's triangles


def _node_matrix(node: pygltflib.Node) -> np.ndarray:
    if node.matrix:
        return np.asarray(node.matrix, dtype=np.float64).reshape(4, 4).T  # column-major
    T = np.eye(4)
    if node.scale:
        T = np.diag([*node.scale, 1.0])
    if node.rotation:
        from scipy.spatial.transform import Rotation

        R = np.eye(4)
        R[:3, :3] = Rotation.from_quat(node.rotation).as_matrix()  # glTF: x y z w, as scipy
        T = R @ T
    if node.translation:
        T[:3, 3] += np.asarray(node.translation, dtype=np.float64)
    return T


def _accessor_view(gltf: pygltflib.GLTF2, blob: bytes | bytearray, index: int) -> tuple[int, int, int, np.dtype, int]:
    """(byte offset, stride, count, component dtype, components) of a plain accessor."""
    acc = gltf.accessors[index]
    if acc.sparse is not None or acc.bufferView is None:
        raise _Bad(f"accessor {index} is sparse or has no buffer view (not supported)")
    view = gltf.bufferViews[acc.bufferView]
    if view.buffer != 0:
        raise _Bad("only data in the .glb's own binary chunk is supported")
    dtype = {5120: "i1", 5121: "u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}[acc.componentType]
    comps = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[acc.type]
    item = np.dtype(dtype).itemsize * comps
    stride = view.byteStride or item
    offset = (view.byteOffset or 0) + (acc.byteOffset or 0)
    if offset + stride * (acc.count - 1) + item > len(blob):
        raise _Bad(f"accessor {index} reaches past the end of the binary chunk")
    return offset, stride, acc.count, np.dtype(dtype), comps


def _read_accessor(gltf, blob, index: int) -> np.ndarray:
    offset, stride, count, dtype, comps = _accessor_view(gltf, blob, index)
    rows = np.ndarray((count, comps), dtype=dtype, buffer=blob, offset=offset,
                      strides=(stride, dtype.itemsize))
    return np.array(rows)


def _write_accessor(blob: bytearray, gltf, index: int, rows: np.ndarray, values: np.ndarray) -> None:
    offset, stride, count, dtype, comps = _accessor_view(gltf, blob, index)
    view = np.ndarray((count, comps), dtype=dtype, buffer=blob, offset=offset,
                      strides=(stride, dtype.itemsize))
    view[rows] = values.astype(dtype)


def _placed_meshes(gltf: pygltflib.GLTF2) -> list[tuple[int, np.ndarray]]:
    """(mesh, world matrix) of each mesh, at its first placement in the scene."""
    scenes = gltf.scenes or []
    scene = scenes[gltf.scene or 0] if scenes else None
    roots = scene.nodes if scene is not None else list(range(len(gltf.nodes)))
    placed: dict[int, np.ndarray] = {}
    stack = [(r, np.eye(4)) for r in reversed(roots or [])]
    while stack:
        i, parent = stack.pop()
        node = gltf.nodes[i]
        world = parent @ _node_matrix(node)
        if node.mesh is not None and node.mesh not in placed:
            placed[node.mesh] = world
        stack += [(c, world) for c in reversed(node.children or [])]
    return sorted(placed.items())


def read(path: str, data: bytes) -> Document:
    """Read a .glb into a :class:`Document` (raises _Bad for a bad file)."""
    gltf = _load(data)
    blob = gltf.binary_blob() or b""
    prims = _triangle_primitives(gltf, blob)
    if not prims.slots:
        raise _Bad("file has no triangle meshes")
    P = np.concatenate(prims.points)
    file_tri = np.concatenate(prims.tris)
    welded, inverse = _weld_map(P)
    faces = inverse[file_tri]
    group = _normal_groups(np.concatenate(prims.normals), inverse)
    uv = sum(1 for s in gltf.meshes for p in s.primitives if p.attributes.TEXCOORD_0 is not None)
    extras = _extras(gltf, uv, prims.skipped)
    rgba = _engine_colors(prims, welded, inverse)
    native = GlbNative(gltf=gltf, slots=prims.slots, file_vertex=inverse, rest=welded,
                       normal_group=group.reshape(-1), n_groups=int(group.max()) + 1,
                       file_triangles=file_tri)
    texturing = None
    if uv or gltf.materials:
        sizes, uvs, materials = [len(p) for p in prims.points], prims.uvs, prims.materials  # (not all of prims)
        texturing = lambda: _texturing(gltf, blob, uvs, sizes, file_tri, materials)  # noqa: E731
    return Document(mesh=_mesh(welded, faces), format="glb", native=native, colors=rgba,
                    normals=any(s.normal is not None for s in prims.slots), extras=extras, texturing=texturing)


def _load(data: bytes) -> pygltflib.GLTF2:
    """The file's glTF, or _Bad."""
    if data[:4] != b"glTF":
        raise _Bad("not a glTF binary file (it does not start with 'glTF')")
    try:
        gltf = pygltflib.GLTF2.load_from_bytes(data)
    except Exception as exc:  # noqa: BLE001 -- pygltflib raises many kinds
        raise _Bad(f"not a valid glTF binary file ({type(exc).__name__}: {exc})") from None
    if gltf is None:
        raise _Bad("not a valid glTF binary file (no JSON chunk)")
    return gltf


@dataclass
class _Primitives:
    """The triangle primitives of a scene, in world space, one entry each in file vertex order."""

    slots: list[_Slot] = field(default_factory=list)
    points: list[np.ndarray] = field(default_factory=list)  # (k, 3) world positions
    normals: list[np.ndarray] = field(default_factory=list)  # (k, 3) world normals (0 where none)
    tris: list[np.ndarray] = field(default_factory=list)  # (t, 3) file vertex indices over all primitives
    colors: list[np.ndarray | None] = field(default_factory=list)  # (k, 4) RGBA, None where none
    uvs: list[int | None] = field(default_factory=list)  # TEXCOORD_0 accessor
    materials: list[tuple[int, int]] = field(default_factory=list)  # (triangles, material or -1)
    skipped: int = 0  # primitives that are not triangles with positions
    first: int = 0  # file vertices so far


def _triangle_primitives(gltf: pygltflib.GLTF2, blob: bytes) -> _Primitives:
    """Every triangle primitive of every mesh the scene places, in world space."""
    found = _Primitives()
    for mesh_index, world in _placed_meshes(gltf):
        for k, prim in enumerate(gltf.meshes[mesh_index].primitives):
            mode = _TRIANGLES if prim.mode is None else prim.mode
            if mode != _TRIANGLES or prim.attributes.POSITION is None:
                found.skipped += 1
                continue
            _add_primitive(found, gltf, blob, mesh_index, world, prim)
            found.slots[-1].primitive = k
    return found


def _add_primitive(found: _Primitives, gltf: pygltflib.GLTF2, blob: bytes, mesh_index: int, world: np.ndarray,
                   prim: pygltflib.Primitive) -> None:
    """One triangle primitive of mesh ``mesh_index``, placed by ``world``, added to ``found``."""
    local = _read_accessor(gltf, blob, prim.attributes.POSITION).astype(np.float64)
    if local.shape[1] != 3:
        raise _Bad("POSITION must be 3 floats a vertex")
    idx = (np.arange(len(local)) if prim.indices is None
           else _read_accessor(gltf, blob, prim.indices).reshape(-1).astype(np.int64))
    if len(idx) % 3 or (idx.size and idx.max() >= len(local)):
        raise _Bad(f"mesh {mesh_index}: indices are not triangles of its vertices")
    pts = local @ world[:3, :3].T + world[:3, 3]
    nrm_index = prim.attributes.NORMAL
    if nrm_index is not None:
        nrm = _read_accessor(gltf, blob, nrm_index).astype(np.float64)
        nrm = nrm @ np.linalg.inv(world[:3, :3])  # (M^-T n) as rows
    else:
        nrm = np.zeros_like(pts)
    found.slots.append(_Slot(prim.attributes.POSITION, nrm_index, world, found.first, mesh_index))
    found.colors.append(None if prim.attributes.COLOR_0 is None
                        else _rgba(_read_accessor(gltf, blob, prim.attributes.COLOR_0), len(local)))
    found.uvs.append(prim.attributes.TEXCOORD_0)
    found.materials.append((len(idx) // 3, -1 if prim.material is None else prim.material))
    found.points.append(pts)
    found.normals.append(nrm)
    found.tris.append(idx.reshape(-1, 3) + found.first)
    found.first += len(local)


def _normal_groups(N: np.ndarray, inverse: np.ndarray) -> np.ndarray:
    """The normal group of each file vertex: its engine vertex and its normal's direction (3 decimals)."""
    length = np.linalg.norm(N, axis=1, keepdims=True)
    unit = np.round(np.divide(N, length, out=np.zeros_like(N), where=length > 0), 3)
    key = np.column_stack([inverse.astype(np.float64), unit])
    _, group = np.unique(key, axis=0, return_inverse=True)
    return group


def _extras(gltf: pygltflib.GLTF2, uv: int, skipped: int) -> dict[str, int]:
    """What the file holds besides the surface, as a document's inventory (``uv``: primitives
    with texture coordinates, ``skipped``: primitives not read)."""
    extras: dict[str, int] = {}
    if uv:
        extras["primitives with texture coordinates"] = uv
    if gltf.materials:
        extras["materials"] = len(gltf.materials)
    if gltf.images:
        extras["embedded images"] = len(gltf.images)
    if skipped:
        extras["non-triangle primitives"] = skipped
    maps = sum(1 for m in gltf.materials or [] if m.normalTexture or m.occlusionTexture or m.emissiveTexture
               or (m.pbrMetallicRoughness and m.pbrMetallicRoughness.metallicRoughnessTexture))
    if maps:
        extras["materials' maps besides the base colour (normal, occlusion, emissive, metallic-roughness)"] = maps
    return extras


def _engine_colors(prims: _Primitives, welded: np.ndarray, inverse: np.ndarray) -> np.ndarray | None:
    """(n, 4) RGBA per engine vertex: its first file vertex's (white where a primitive has none);
    None when no primitive has colours."""
    if not any(c is not None for c in prims.colors):
        return None
    file_rgba = np.concatenate([np.ones((len(p), 4)) if c is None else c for c, p in zip(prims.colors, prims.points)])
    first_of = np.full(len(welded), len(inverse), dtype=np.int64)
    np.minimum.at(first_of, inverse, np.arange(len(inverse)))
    return file_rgba[first_of]


def _texturing(gltf: pygltflib.GLTF2, blob: bytes, uvs: list[int | None], sizes: list[int],
               file_tri: np.ndarray, prim_material: list[tuple[int, int]]) -> Texturing:
    """TEXCOORD_0 of every triangle corner (v flipped to OBJ's bottom-left origin) and each
    triangle's material (base colour factor and texture image)."""
    tex = Texturing()
    if any(u is not None for u in uvs):
        rows, has = [], []
        for index, size in zip(uvs, sizes):
            if index is None:
                rows.append(np.zeros((size, 2)))
                has.append(np.zeros(size, dtype=bool))
                continue
            values = _read_accessor(gltf, blob, index)
            scale = {np.dtype("u1"): 255.0, np.dtype("<u2"): 65535.0}.get(values.dtype, 1.0)
            values = values[:, :2].astype(np.float64) / scale
            if len(values) != size:
                raise _Bad(f"accessor {index}: TEXCOORD_0 has {len(values)} values for {size} vertices")
            rows.append(np.column_stack([values[:, 0], 1.0 - values[:, 1]]))
            has.append(np.ones(size, dtype=bool))
        tex.uv = np.concatenate(rows)
        corner = file_tri.reshape(-1)
        tex.corner_uv = np.where(np.concatenate(has)[corner], corner, -1)
    for k, m in enumerate(gltf.materials or []):
        pbr = m.pbrMetallicRoughness
        color = tuple(float(c) for c in (pbr.baseColorFactor if pbr and pbr.baseColorFactor else (1, 1, 1, 1)))
        material = Material(m.name or f"material_{k}", color=color)
        info = pbr.baseColorTexture if pbr else None
        if info is not None and info.index is not None and info.index < len(gltf.textures or []):
            source = gltf.textures[info.index].source
            if source is not None and source < len(gltf.images or []):
                image = gltf.images[source]
                if image.bufferView is not None:
                    view = gltf.bufferViews[image.bufferView]
                    start = view.byteOffset or 0
                    material.image = bytes(blob[start: start + view.byteLength])
                    ext = {"image/jpeg": ".jpg", "image/png": ".png"}.get(image.mimeType or "", ".png")
                    stem = (image.name or material.name or f"texture_{source}").rsplit(".", 1)[0]
                    material.image_name = stem + ext
        tex.materials.append(material)
    if tex.materials:
        tex.face_material = np.concatenate([np.full(n, m, dtype=np.int64) for n, m in prim_material])
    return tex


def _rgba(values: np.ndarray, count: int) -> np.ndarray:
    """COLOR_0 values (linear; float, or normalized unsigned byte / short; RGB or RGBA) as (count, 4)
    display (sRGB) floats in [0, 1], alpha as stored (1 where there is none)."""
    if len(values) != count or values.shape[1] not in (3, 4):
        raise _Bad("COLOR_0 must be 3 or 4 values for each vertex")
    scale = {np.dtype("u1"): 255.0, np.dtype("<u2"): 65535.0}.get(values.dtype, 1.0)
    rgba = np.ones((count, 4))
    rgba[:, :values.shape[1]] = values.astype(np.float64) / scale
    return linear_to_srgb(np.clip(rgba, 0.0, 1.0))


def _weld_map(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct rows of ``points`` in first-occurrence order and the index of each row."""
    p = points + 0.0
    _, first, inverse = np.unique(p, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return p[first[order]], rank[inverse.reshape(-1)]


def write(doc: Document) -> bytes:
    """The .glb bytes of ``doc``: the file it was read from with new positions and normals,
    or a plain .glb when it was read from another format."""
    nat = doc.native
    if not isinstance(nat, GlbNative):
        return _plain(doc)
    gltf = copy.deepcopy(nat.gltf)
    blob = bytearray(nat.gltf.binary_blob() or b"")
    V = doc.mesh.vertices
    moved = moved_vertices(nat.rest, V)
    file_moved = moved[nat.file_vertex]
    world_pts = V[nat.file_vertex]
    touched = np.zeros(len(nat.file_vertex), dtype=bool)
    tri_moved = file_moved[nat.file_triangles].any(axis=1)
    touched[nat.file_triangles[tri_moved].ravel()] = True
    groups = nat.normal_group[nat.file_triangles]
    normals, valid = grouped_normals(V[nat.file_vertex], nat.file_triangles, groups, nat.n_groups)
    bounds = [s.first for s in nat.slots] + [len(nat.file_vertex)]
    for s, end in zip(nat.slots, bounds[1:]):
        rows = np.flatnonzero(file_moved[s.first:end])
        inv = np.linalg.inv(s.world)
        if rows.size:
            local = world_pts[s.first + rows] @ inv[:3, :3].T + inv[:3, 3]
            _write_accessor(blob, gltf, s.position, rows, local)
            allpos = _read_accessor(gltf, blob, s.position)
            acc = gltf.accessors[s.position]
            acc.min = allpos.min(axis=0).astype(float).tolist()
            acc.max = allpos.max(axis=0).astype(float).tolist()
        if s.normal is not None:
            rows = np.flatnonzero(touched[s.first:end])
            g = nat.normal_group[s.first + rows]
            rows, g = rows[valid[g]], g[valid[g]]
            if rows.size:
                n = normals[g] @ s.world[:3, :3]  # back to the node's space: M^T n
                n /= np.linalg.norm(n, axis=1, keepdims=True)
                _write_accessor(blob, gltf, s.normal, rows, n)
    gltf.set_binary_blob(bytes(blob))
    return b"".join(gltf.save_to_bytes())


def _plain(doc: Document) -> bytes:
    """A .glb of ``doc`` (from another format): see :func:`plain_glb`."""
    return plain_glb(doc).buffer.finish()


@dataclass(eq=False)
class PlainGlb:
    """A new .glb of a document, its binary chunk still open for more (:mod:`.glb_morphs` adds targets).

    Attributes
    ----------
    buffer : GltfBuffer
        The glTF (one mesh, ``buffer.gltf.meshes[0]``, placed by node 0) and its binary chunk.
    source : (k,) int64
        The document vertex of each glTF vertex (0..n-1 first, then the copies made at UV seams).
    """

    buffer: GltfBuffer
    source: np.ndarray


def plain_glb(doc: Document) -> PlainGlb:
    """A .glb of ``doc`` (from another format) written with pygltflib: its triangles, vertex
    normals, colours (made linear, as ``COLOR_0`` holds them), texture coordinates (vertices
    split where a vertex's corners have different ones, the document's vertices first and in
    order) and materials (base colour and its texture image, embedded), one primitive per
    material."""
    mesh = doc.mesh
    counts, flat = doc.polygon_lists()
    tex = doc.textures()
    has_uv = tex is not None and tex.uv is not None and tex.corner_uv is not None
    if has_uv:
        source, uv, corner = tex.vertex_split(mesh.n_vertices, flat)
    else:
        source, uv, corner = np.arange(mesh.n_vertices), None, flat
    triangles = fan_triangles(counts, corner)  # in the engine's triangle order
    materials = tex.materials if tex is not None else []
    face_material = np.full(len(counts), -1, dtype=np.int64)
    if materials and tex.face_material is not None:
        face_material = tex.face_material
    tri_material = np.repeat(face_material, counts - 2)
    out = GltfBuffer(pygltflib.GLTF2(asset=pygltflib.Asset(generator="hybridedit", version="2.0"),
                                     scene=0, scenes=[pygltflib.Scene(nodes=[0])], nodes=[pygltflib.Node(mesh=0)]))
    gltf = out.gltf
    attributes = pygltflib.Attributes(
        POSITION=out.accessor(mesh.vertices[source].astype("<f4"), minmax=True),
        NORMAL=out.accessor(vertex_normals(mesh.vertices, mesh.faces)[source].astype("<f4")))
    if has_uv:
        attributes.TEXCOORD_0 = out.accessor(np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]).astype("<f4"))
    if doc.colors is not None:
        attributes.COLOR_0 = out.accessor(srgb_to_linear(doc.colors[source]).astype("<f4"))  # (glTF's are linear)
    for m in materials:
        pbr = pygltflib.PbrMetallicRoughness(baseColorFactor=[float(c) for c in m.color], metallicFactor=0.0,
                                             roughnessFactor=1.0)
        if m.image is not None:
            image = out.image(m.image, m.image_name)
            if not gltf.samplers:
                gltf.samplers.append(pygltflib.Sampler())
            gltf.textures.append(pygltflib.Texture(source=image, sampler=0))
            pbr.baseColorTexture = pygltflib.TextureInfo(index=len(gltf.textures) - 1)
        gltf.materials.append(pygltflib.Material(name=m.name, pbrMetallicRoughness=pbr))
    primitives = []
    cuts = np.flatnonzero(np.diff(tri_material)) + 1
    for lo, hi in zip(np.r_[0, cuts].tolist(), np.r_[cuts, len(triangles)].tolist()):
        if hi <= lo:
            continue
        indices = out.accessor(triangles[lo:hi].reshape(-1).astype("<u4"), target=pygltflib.ELEMENT_ARRAY_BUFFER)
        material = int(tri_material[lo])
        primitives.append(pygltflib.Primitive(attributes=attributes, indices=indices, mode=_TRIANGLES,
                                              material=None if material < 0 else material))
    gltf.meshes.append(pygltflib.Mesh(primitives=primitives))
    return PlainGlb(out, source)
