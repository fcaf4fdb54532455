"""Reading pose files back as their clients do, and the validators that check them: pygltflib for glTF
morph targets, ``pxr`` (UsdSkel) for USD blend shapes, the Khronos glTF Validator (an npm package,
scripts/gltf-validator) and USD's validators (what ``usdchecker`` runs). Where node, the validator or
usd-core is missing, a test using them is skipped, unless HYBRIDEDIT_REQUIRE_VALIDATORS is set
(.ci/run sets it), where that fails instead.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pygltflib
import pytest

from shapes import REPO

VALIDATOR = REPO / "scripts" / "gltf-validator"
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
