"""Poses as glTF 2.0 morph targets: one mesh, one target per pose (.glb, and .gltf with the buffer inline).

The rest mesh is written as :mod:`.glb` writes the document (a .glb read from a file: that file with
the rest positions, everything else kept; a document of another format: a new .glb with its UVs,
normals, colours (made linear, as ``COLOR_0`` holds them), materials and texture images), then
every triangle primitive gets one morph target per pose: POSITION deltas (float32, with the min and
max the spec requires) and, with ``normals``, NORMAL deltas (the pose's normals, recomputed as
:mod:`.glb` does, minus the rest's), only where a moved vertex touches them. A target whose deltas
are mostly zero (a pose moves a region) is a sparse accessor, its non-zero rows only; one moving
nothing is an accessor without data (all zeros). The targets' names go in ``mesh.extras.targetNames``
(what three.js, Babylon.js and Blender read), their weights are 0: the file opens at rest.
"""

from __future__ import annotations

import base64

import numpy as np
import pygltflib

from ..document import Document
from ...core.normals import grouped_normals, vertex_normals
from . import glb
from .glb_buffer import GltfBuffer

__all__ = ["write", "write_gltf"]


def write(doc: Document, poses: np.ndarray, names: list[str], *, normals: bool = True,
          sparse: bool = True) -> bytes:
    """The .glb bytes of ``doc``'s mesh at rest with one morph target per pose.

    Parameters
    ----------
    doc : Document
        Its ``mesh.vertices`` (n, 3) are the rest.
    poses : (k, n, 3) float64
        Each pose's positions (finite; checked by the caller).
    names : list of k str
    normals : bool
        Write NORMAL deltas too.
    sparse : bool
        Let a target that is mostly zero be a sparse accessor.
    """
    if isinstance(doc.native, glb.GlbNative):
        buffer, meshes = _native_targets(doc, poses, normals=normals, sparse=sparse)
    else:
        buffer, meshes = _plain_targets(doc, poses, normals=normals, sparse=sparse)
    for mesh in meshes:
        _name_targets(buffer.gltf, mesh, names)
    return buffer.finish()


def write_gltf(doc: Document, poses: np.ndarray, names: list[str], *, normals: bool = True,
               sparse: bool = True) -> bytes:
    """The same as :func:`write`, as a .gltf (JSON) with its buffer inline (a base64 data URI)."""
    gltf = _loaded(write(doc, poses, names, normals=normals, sparse=sparse))
    blob = gltf.binary_blob() or b""
    gltf.buffers[0].uri = "data:application/octet-stream;base64," + base64.b64encode(blob).decode("ascii")
    return gltf.gltf_to_json().encode("utf-8")


def _plain_targets(doc: Document, poses: np.ndarray, *, normals: bool,
                   sparse: bool) -> tuple[GltfBuffer, list[pygltflib.Mesh]]:
    """A new .glb of ``doc`` (:func:`.glb.plain_glb`) with the targets on its one mesh."""
    plain = glb.plain_glb(doc)
    out, source = plain.buffer, plain.source
    rest, faces = doc.mesh.vertices, doc.mesh.faces
    rest32 = rest[source].astype("<f4").astype(np.float64)  # (what POSITION holds)
    rest_normals = vertex_normals(rest, faces)[source].astype("<f4").astype(np.float64)
    targets = []
    for P in poses:
        moved = np.any(P != rest, axis=1)
        delta = np.where(moved[source, None], P[source] - rest32, 0.0).astype("<f4")
        target = {"POSITION": out.delta_accessor(delta, sparse=sparse, minmax=True)}
        if normals:
            touched = _touched(moved, faces)[source]
            change = np.where(touched[:, None], vertex_normals(P, faces)[source] - rest_normals, 0.0)
            target["NORMAL"] = out.delta_accessor(change.astype("<f4"), sparse=sparse, minmax=False)
        targets.append(target)
    mesh = out.gltf.meshes[0]
    for prim in mesh.primitives:
        prim.targets = list(targets)
    mesh.weights = [0.0] * len(targets)
    return out, [mesh]


def _native_targets(doc: Document, poses: np.ndarray, *, normals: bool,
                    sparse: bool) -> tuple[GltfBuffer, list[pygltflib.Mesh]]:
    """The .glb ``doc`` was read from, at ``doc``'s rest positions (:func:`.glb.write`), with the
    targets appended to every primitive of every mesh the document's surface comes from."""
    nat: glb.GlbNative = doc.native
    gltf = _loaded(glb.write(doc))
    out = GltfBuffer(gltf, gltf.binary_blob() or b"")
    rest = doc.mesh.vertices
    bounds = [s.first for s in nat.slots] + [len(nat.file_vertex)]
    spans = [(s, np.arange(s.first, end)) for s, end in zip(nat.slots, bounds[1:])]
    local_rest = {id(s): glb._read_accessor(gltf, out.blob, s.position).astype(np.float64) for s, _ in spans}
    rest_normal = {id(s): glb._read_accessor(gltf, out.blob, s.normal).astype(np.float64)
                   for s, _ in spans if s.normal is not None}
    meshes = sorted({s.mesh for s in nat.slots})
    old = {m: _target_count(gltf.meshes[m]) for m in meshes}
    for P in poses:
        moved = np.any(P != rest, axis=1)[nat.file_vertex]  # (per file vertex)
        if normals:
            touched = _touched(moved, nat.file_triangles)
            groups = nat.normal_group[nat.file_triangles]
            pose_normals, valid = grouped_normals(P[nat.file_vertex], nat.file_triangles, groups, nat.n_groups)
        made = set()
        for s, rows in spans:
            inv = np.linalg.inv(s.world)
            local = P[nat.file_vertex[rows]] @ inv[:3, :3].T + inv[:3, 3]
            delta = np.where(moved[rows, None], local - local_rest[id(s)], 0.0).astype("<f4")
            target = {"POSITION": out.delta_accessor(delta, sparse=sparse, minmax=True)}
            if normals and s.normal is not None:
                g = nat.normal_group[rows]
                use = touched[rows] & valid[g]
                n = pose_normals[g] @ s.world[:3, :3]  # back to the node's space: M^T n
                n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
                change = np.where(use[:, None], n - rest_normal[id(s)], 0.0).astype("<f4")
                target["NORMAL"] = out.delta_accessor(change, sparse=sparse, minmax=False)
            gltf.meshes[s.mesh].primitives[s.primitive].targets.append(target)
            made.add((s.mesh, s.primitive))
        for m in meshes:  # every primitive of a mesh has as many targets: zeros for lines, points
            for k, prim in enumerate(gltf.meshes[m].primitives):
                if (m, k) not in made:
                    prim.targets.append(_zero_target(gltf, prim))
    for m in meshes:
        _extend_weights(gltf, m, old[m], len(poses))
    return out, [gltf.meshes[m] for m in meshes]


def _loaded(data: bytes) -> pygltflib.GLTF2:
    """A .glb's glTF as pygltflib loads it, less the ``byteOffset`` 0 it gives an accessor without a
    buffer view (which the spec forbids there)."""
    gltf = glb._load(data)
    for acc in gltf.accessors:
        if acc.bufferView is None:
            acc.byteOffset = None
    return gltf


def _touched(moved: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(k,) bool: the vertices of the triangles (t, 3) that have a ``moved`` vertex (their normals change)."""
    touched = np.zeros(len(moved), dtype=bool)
    touched[triangles[moved[triangles].any(axis=1)].ravel()] = True
    return touched


def _zero_target(gltf: pygltflib.GLTF2, prim: pygltflib.Primitive) -> dict[str, int]:
    """A target that moves nothing, for a primitive that is not part of the surface (lines, points)."""
    if prim.attributes.POSITION is None:
        return {}
    count = gltf.accessors[prim.attributes.POSITION].count
    gltf.accessors.append(pygltflib.Accessor(byteOffset=None, componentType=pygltflib.FLOAT, count=count,
                                             type=pygltflib.VEC3, min=[0.0] * 3, max=[0.0] * 3))
    return {"POSITION": len(gltf.accessors) - 1}


def _target_count(mesh: pygltflib.Mesh) -> int:
    """The targets a mesh has before ours (as many on each primitive, as the spec requires)."""
    return len(mesh.primitives[0].targets or []) if mesh.primitives else 0


def _extend_weights(gltf: pygltflib.GLTF2, m: int, old: int, added: int) -> None:
    """Mesh ``m``'s default weights, and those of the nodes that place it, with a 0 for each new target."""
    mesh = gltf.meshes[m]
    mesh.weights = list(mesh.weights or [0.0] * old) + [0.0] * added
    for node in gltf.nodes or []:
        if node.mesh == m and getattr(node, "weights", None):  # (pygltflib 1.16 has no Node.weights)
            node.weights = list(node.weights) + [0.0] * added


def _name_targets(gltf: pygltflib.GLTF2, mesh: pygltflib.Mesh, names: list[str]) -> None:
    """``mesh.extras.targetNames``: a name for each target, those before ours kept (or made up)."""
    extras = mesh.extras if isinstance(mesh.extras, dict) else {}
    total = len(mesh.weights or [])
    before = [str(n) for n in extras.get("targetNames", [])][: total - len(names)]
    before += [f"target_{i}" for i in range(len(before), total - len(names))]
    extras["targetNames"] = before + list(names)
    mesh.extras = extras
