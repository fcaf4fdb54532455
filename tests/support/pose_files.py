"""The pose tests' inputs, and reading pose files back as their clients do, and the validators that
check them: pygltflib for glTF morph targets, Blender's own glTF importer (blender_gltf_import.py here,
run by the Python of blender/.venv-bpy), ``pxr`` (UsdSkel) for USD blend shapes, the Khronos glTF
Validator (an npm package, scripts/gltf-validator) and USD's validators (what ``usdchecker`` runs).
Where node, the validator, Blender or usd-core is missing, a test using them is skipped, unless
HYBRIDEDIT_REQUIRE_VALIDATORS is set (.ci/run sets it), where that fails instead.
"""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import plyfile
import pygltflib
import pytest

from shapes import REPO, icosphere

VALIDATOR = REPO / "scripts" / "gltf-validator"
#: Blender as a Python module: the venv blender/run_tests.sh makes (.ci/run runs it before the suite)
BPY_PYTHON = REPO / "blender" / ".venv-bpy" / "bin" / "python"
BLENDER_IMPORT = Path(__file__).with_name("blender_gltf_import.py")
REQUIRED = bool(os.environ.get("HYBRIDEDIT_REQUIRE_VALIDATORS"))


def _missing(reason: str) -> None:
    if REQUIRED:
        pytest.fail(f"{reason} (HYBRIDEDIT_REQUIRE_VALIDATORS is set)")
    pytest.skip(reason)


def _pxr():
    try:
        import pxr.Usd  # noqa: F401
    except ImportError:
        _missing("usd-core is not installed (pip install 'hybridedit[usd]')")
    from pxr import Usd, UsdGeom, UsdSkel, Vt

    return Usd, UsdGeom, UsdSkel, Vt


# --------------------------------------------------------------------------- inputs


def textured_tube(folder: Path, rows: int = 6, cols: int = 12) -> Path:
    """An open tube of quads along x, its texture coordinates cut along one seam (the seam's
    vertices have two coordinates each), a material and its PNG texture."""
    from PIL import Image

    folder.mkdir(parents=True, exist_ok=True)
    angle = 2 * np.pi * np.arange(cols) / cols
    x = np.linspace(-2.0, 2.0, rows + 1)
    V = np.array([(xi, np.cos(a), np.sin(a)) for xi in x for a in angle])
    vt = np.array([(j / cols, i / rows) for i in range(rows + 1) for j in range(cols + 1)])
    lines = ["mtllib tube.mtl", "usemtl skin"]
    lines += [f"v {a!r} {b!r} {c!r}" for a, b, c in V.tolist()]
    lines += [f"vt {u!r} {v!r}" for u, v in vt.tolist()]
    for i in range(rows):
        for j in range(cols):
            c = [(i, j), (i, j + 1), (i + 1, j + 1), (i + 1, j)]
            lines.append("f " + " ".join(f"{a * cols + b % cols + 1}/{a * (cols + 1) + b + 1}" for a, b in c))
    (folder / "tube.obj").write_text("\n".join(lines) + "\n")
    (folder / "tube.mtl").write_text("newmtl skin\nKd 1 1 1\nmap_Kd skin.png\n")
    pixels = (np.random.default_rng(3).random((8, 8, 3)) * 255).astype(np.uint8)
    buffer = io.BytesIO()
    Image.fromarray(pixels).save(buffer, format="PNG")
    (folder / "skin.png").write_bytes(buffer.getvalue())
    return folder / "tube.obj"


def coloured_ply(path: Path) -> Path:
    """An icosphere with a colour (RGBA bytes, some translucent) at each vertex."""
    m = icosphere(2)
    rgba = (np.random.default_rng(5).random((m.n_vertices, 4)) * 255).astype(np.uint8)
    rgba[::2, 3] = 255
    vertex = np.empty(m.n_vertices, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("red", "u1"),
                                            ("green", "u1"), ("blue", "u1"), ("alpha", "u1")])
    for k, axis in enumerate("xyz"):
        vertex[axis] = m.vertices[:, k]
    for k, channel in enumerate(["red", "green", "blue", "alpha"]):
        vertex[channel] = rgba[:, k]
    face = np.empty(m.n_faces, dtype=[("vertex_indices", "i4", (3,))])
    face["vertex_indices"] = m.faces
    plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex"),
                     plyfile.PlyElement.describe(face, "face")]).write(str(path))
    return path


def region_poses(V: np.ndarray) -> list[np.ndarray]:
    """Four poses: the +x end bent up (a region moves), the whole shape swollen, nothing moved, and
    the -x end twisted."""
    lo, hi = V.min(axis=0), V.max(axis=0)
    t = (V[:, 0] - lo[0]) / (hi[0] - lo[0])  # 0 at -x, 1 at +x
    bent = V.copy()
    end = np.maximum(t - 0.6, 0.0)
    bent[:, 1] += 2.0 * end ** 2
    swollen = V * 1.15 + [0.0, 0.1, 0.0]
    twisted = V.copy()
    a = 1.5 * np.maximum(0.35 - t, 0.0)
    twisted[:, 1] = V[:, 1] * np.cos(a) - V[:, 2] * np.sin(a)
    twisted[:, 2] = V[:, 1] * np.sin(a) + V[:, 2] * np.cos(a)
    return [bent, swollen, V.copy(), twisted]


NAMES = ["bend up", "swell", "rest again", "twist (left)"]


# --------------------------------------------------------------------------- reading glTF back


def accessor(gltf: pygltflib.GLTF2, index: int) -> np.ndarray:
    """An accessor's values as float64 (count, components): its view's rows, or zeros without a
    view, then its sparse rows substituted."""
    acc = gltf.accessors[index]
    comps = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[acc.type]
    dtype = {5121: "u1", 5123: "<u2", 5125: "<u4", 5126: "<f4"}[acc.componentType]
    blob = gltf.binary_blob()
    if acc.bufferView is None:
        out = np.zeros((acc.count, comps))
    else:
        view = gltf.bufferViews[acc.bufferView]
        start = (view.byteOffset or 0) + (acc.byteOffset or 0)
        out = np.frombuffer(blob, dtype, acc.count * comps, start).reshape(-1, comps).astype(np.float64)
    if acc.sparse is not None:
        s = acc.sparse
        iv, vv = gltf.bufferViews[s.indices.bufferView], gltf.bufferViews[s.values.bufferView]
        idt = {5121: "u1", 5123: "<u2", 5125: "<u4"}[s.indices.componentType]
        rows = np.frombuffer(blob, idt, s.count, (iv.byteOffset or 0) + (s.indices.byteOffset or 0))
        assert np.all(np.diff(rows.astype(np.int64)) > 0), "sparse indices must increase"
        values = np.frombuffer(blob, "<f4", s.count * comps, (vv.byteOffset or 0) + (s.values.byteOffset or 0))
        out[rows] = values.reshape(-1, comps)
    return out


def morphed(gltf: pygltflib.GLTF2, prim: pygltflib.Primitive, target: int, attribute: str = "POSITION"):
    """The primitive's ``attribute`` with target ``target`` at weight 1 (the rest plus its deltas)."""
    rest = accessor(gltf, getattr(prim.attributes, attribute))
    return rest + accessor(gltf, prim.targets[target][attribute])  # (pygltflib reads targets as dicts)


def validate_gltf(path: Path) -> dict:
    """The Khronos glTF Validator's report on ``path`` (skips where node or the validator is missing)."""
    node = shutil.which("node")
    if node is None:
        _missing("node is not installed (the glTF Validator runs in it)")
    if not (VALIDATOR / "node_modules" / "gltf-validator").is_dir():
        _missing(f"the glTF Validator is not installed: npm ci --prefix {VALIDATOR.relative_to(REPO)}")
    run = subprocess.run([node, str(VALIDATOR / "validate.mjs"), str(path)], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode in (0, 1), run.stderr
    return json.loads(run.stdout)


def blender_import(path: Path) -> dict[str, np.ndarray]:
    """What Blender's own glTF importer makes of ``path``: tests/support/blender_gltf_import.py's dump
    (its docstring lists the arrays), run by the Python of blender/.venv-bpy, or of
    HYBRIDEDIT_BPY_PYTHON where that is set (skips where there is none)."""
    python = Path(os.environ.get("HYBRIDEDIT_BPY_PYTHON") or BPY_PYTHON)
    if not python.is_file():
        _missing(f"no Python with Blender as a module at {python} (bash blender/run_tests.sh makes it; "
                 f"or set HYBRIDEDIT_BPY_PYTHON)")
    out = path.with_name(path.stem + "_blender.npz")
    # -I: none of this process's PYTHONPATH or user site in Blender's Python
    run = subprocess.run([str(python), "-I", str(BLENDER_IMPORT), str(path), str(out)], capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, (run.stdout[-3000:], run.stderr[-3000:])
    print(run.stdout.splitlines()[-1])
    with np.load(out) as dump:
        return {name: dump[name] for name in dump.files}


def usd_check(path: Path) -> list[str]:
    """What USD's validators (those ``usdchecker`` runs) find in ``path``: one line each."""
    Usd, *_ = _pxr()
    stage = Usd.Stage.Open(str(path))
    try:
        from pxr import UsdValidation
    except ImportError:  # usd-core before UsdValidation: the compliance checker of old usdchecker
        from pxr import UsdUtils

        checker = UsdUtils.ComplianceChecker(rootPackageOnly=False, skipVariants=False)
        checker.CheckCompliance(str(path))
        return checker.GetErrors() + checker.GetFailedChecks() + checker.GetWarnings()
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    assert len(validators) >= 20
    return [f"{e.GetName()}: {e.GetMessage()}" for e in UsdValidation.ValidationContext(validators).Validate(stage)]


def usd_poses(path: Path, rest: np.ndarray) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(blend shape names, (k, n, 3) each blend shape at weight 1 alone, (k,) the animation's weights),
    computed by UsdSkel from the skeleton binding as a client resolves it."""
    Usd, UsdGeom, UsdSkel, Vt = _pxr()
    stage = Usd.Stage.Open(str(path))
    root = UsdSkel.Root(stage.GetDefaultPrim())
    cache = UsdSkel.Cache()
    cache.Populate(root, Usd.PrimDefaultPredicate)
    (binding,) = cache.ComputeSkelBindings(root, Usd.PrimDefaultPredicate)
    (target,) = binding.GetSkinningTargets()
    assert target.HasBlendShapes()
    anim = cache.GetSkelQuery(binding.GetSkeleton()).GetAnimQuery()
    assert list(anim.GetBlendShapeOrder()) == list(target.GetBlendShapeOrder())
    query = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(target.GetPrim()))
    offsets, indices = query.ComputeSubShapePointOffsets(), query.ComputeBlendShapePointIndices()
    points = UsdGeom.Mesh(target.GetPrim()).GetPointsAttr().Get()
    np.testing.assert_allclose(np.array(points), rest, atol=1e-6 * np.linalg.norm(np.ptp(rest, axis=0)))
    k = query.GetNumBlendShapes()
    posed = []
    for i in range(k):
        weights = query.ComputeSubShapeWeights(Vt.FloatArray([float(i == j) for j in range(k)]))
        P = Vt.Vec3fArray(points)
        assert query.ComputeDeformedPoints(*weights, indices, offsets, P)
        posed.append(np.array(P, dtype=np.float64))
    return [str(t) for t in target.GetBlendShapeOrder()], np.array(posed), np.array(anim.ComputeBlendShapeWeights())
