"""hybridedit batch --pack glb|usd: one file per input holding all its poses, each equal to the replay of
its edit file; read back by pygltflib and pxr, checked by the Khronos validator; resumed without redoing
what is made."""

from __future__ import annotations

import contextlib
import os
import shutil

import numpy as np
import pygltflib
import pytest

import hybridedit as he
from hybridedit.batching.api import run
from hybridedit.batching.manifest import Manifest, file_sha256
from hybridedit.batching.plan import STAGING, find_inputs, plan_jobs
from hybridedit.batching.settings import BatchSettings, PoseSettings
from hybridedit.batching.tasks import bind_input, pose_output
from hybridedit.cli import main
from hybridedit.fileio.meshfiles import read_document

from support.pose_files import morphed, usd_check, usd_poses, validate_gltf


def rows(table) -> list[dict]:
    return table.to_pylist()


def pack_settings(cage, **kw) -> BatchSettings:
    return BatchSettings(**{"poses": 3, "seed": 11, "cage_size": cage, "pack": "glb", **kw})


@pytest.fixture(scope="module")
def packed(inputs, client2, tmp_path_factory, cage):
    """Three poses of each input (blob.obj, long.ply), packed as .glb on the two workers."""
    out = tmp_path_factory.mktemp("batch-packed")
    result = run([inputs], out, settings=pack_settings(cage), client=client2, progress=False)
    return out, result


def replayed(row: dict, out, scratch) -> np.ndarray:
    """The pose of ``row`` made again by ``hybridedit deform`` from its edit file (binary PLY: exact)."""
    again = scratch / f"again-{row['pose']}.ply"
    assert main(["deform", row["input"], "-o", str(again), "--edit", str(out / row["edit"]), "-q"]) == 0
    return he.read_mesh(again).vertices


def glb_poses(path) -> tuple[list[str], list[np.ndarray], np.ndarray]:
    """(target names, each target's positions per engine vertex, the engine vertex of each file vertex)."""
    gltf = pygltflib.GLTF2.load(str(path))
    (mesh,) = gltf.meshes
    (prim,) = mesh.primitives
    file_vertex = read_document(path).native.file_vertex
    return mesh.extras["targetNames"], [morphed(gltf, prim, k) for k in range(len(prim.targets))], file_vertex


def test_one_pack_per_input_holds_every_pose_as_its_edit_file_replays(packed, tmp_path):
    out, result = packed
    table = result.table
    assert (result.made, result.skipped, result.failed) == (6, 0, 0)
    assert sorted(p.name for p in out.iterdir() if not p.name.endswith(".edit.json")) == \
        ["blob-poses.glb", "long-poses.glb", "manifest.parquet"]  # no mesh per pose, nothing left staged
    assert [r["output"] for r in rows(table)] == [f"{s}-poses.glb#pose-00{k}" for s in ("blob", "long")
                                                  for k in range(3)]
    for stem in ("blob", "long"):
        mine = [r for r in rows(table) if r["pack"] == f"{stem}-poses.glb"]
        assert len(mine) == 3 and all(r["status"] == "done" for r in mine)
        assert {r["pack_sha256"] for r in mine} == {file_sha256(out / f"{stem}-poses.glb")}
        names, targets, file_vertex = glb_poses(out / f"{stem}-poses.glb")
        assert names == ["pose-000", "pose-001", "pose-002"]
        rest = he.read_mesh(mine[0]["input"]).vertices
        diagonal = np.linalg.norm(np.ptp(rest, axis=0))
        for r, target in zip(mine, targets):
            assert r["output_sha256"] is None and r["edit_sha256"] == file_sha256(out / r["edit"])
            assert r["moved"] >= 2.0 and r["pack_seconds"] > 0
            assert np.abs(target - replayed(r, out, tmp_path)[file_vertex]).max() <= 1e-6 * diagonal


def test_the_khronos_validator_finds_nothing_wrong_in_a_pack(packed):
    out, _ = packed
    for stem in ("blob", "long"):
        issues = validate_gltf(out / f"{stem}-poses.glb")["issues"]
        assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]


def test_a_rerun_redoes_nothing_and_more_poses_extend_the_pack(inputs, packed, client2, tmp_path, cage):
    out, first = packed
    folder = tmp_path / "out"
    shutil.copytree(out, folder)
    stamp = {p.name: os.stat(p).st_mtime_ns for p in folder.glob("*-poses.glb")}
    again = run([inputs], folder, settings=pack_settings(cage), client=client2, progress=False)
    assert (again.made, again.skipped, again.failed) == (0, 6, 0)
    assert {p.name: os.stat(p).st_mtime_ns for p in folder.glob("*-poses.glb")} == stamp  # not written again
    assert rows(again.table) == rows(first.table)
    # a fourth pose: posed alone; the pack is written again, the three before replayed from their edits
    before = glb_poses(folder / "blob-poses.glb")[1]
    more = run([inputs], folder, settings=pack_settings(cage, poses=4), client=client2, progress=False)
    assert (more.made, more.skipped, more.failed) == (2, 6, 0)
    names, targets, _ = glb_poses(folder / "blob-poses.glb")
    assert names == ["pose-000", "pose-001", "pose-002", "pose-003"]
    diagonal = he.read_mesh(inputs / "blob.obj").bbox_diagonal()
    assert all(np.abs(a - b).max() <= 1e-6 * diagonal for a, b in zip(before, targets))
    by = {r["output"]: r for r in rows(more.table)}
    old = {r["output"]: r for r in rows(first.table)}
    assert by["blob-poses.glb#pose-000"]["pose_seconds"] == old["blob-poses.glb#pose-000"]["pose_seconds"]
    assert by["blob-poses.glb#pose-000"]["pack_sha256"] == file_sha256(folder / "blob-poses.glb")


def test_a_staged_pose_is_packed_without_posing_it_again(inputs, client2, tmp_path, cage):
    """A batch killed after a pose was made, before its pack: the re-run packs that pose from its
    staged file (its row, timings included, is the one made then) and poses only the others."""
    settings = pack_settings(cage, poses=2)
    out = tmp_path / "out"
    found = find_inputs([inputs / "blob.obj"])
    job = plan_jobs(found, poses=2, edits=None, output_format=None, pack=".glb")[0]
    row = pose_output(bind_input(job.input, cage), job, settings, str(out))
    assert row["status"] == "posed" and (out / STAGING / "blob-poses.glb" / "pose-000.npy").is_file()
    manifest = Manifest(out)
    manifest.add(row)
    manifest.close()
    result = run([inputs / "blob.obj"], out, settings=settings, client=client2, progress=False)
    assert (result.made, result.skipped, result.failed) == (2, 0, 0)
    first, second = rows(result.table)
    assert first["status"] == second["status"] == "done" and first["pose_seconds"] == row["pose_seconds"]
    assert first["worker"] == "client" != second["worker"]
    assert not (out / STAGING).exists()
    assert glb_poses(out / "blob-poses.glb")[0] == ["pose-000", "pose-001"]


def test_a_failed_pose_is_left_out_of_the_pack_and_its_row_says_why(inputs, client2, tmp_path, cage):
    """Within 15% stretch in two draws, most poses of the blob fail: the pack holds the others."""
    result = run([inputs / "blob.obj"], tmp_path, settings=pack_settings(cage, poses=4, pose=PoseSettings(max_stretch=15.0, tries=2)),
                 client=client2, progress=False)
    table = rows(result.table)
    failed = [r for r in table if r["status"] == "failed"]
    done = [r for r in table if r["status"] == "done"]
    assert failed and done and result.failed == len(failed)
    assert all(r["pack"] is None and "no pose within --max-stretch 15%" in r["message"] for r in failed)
    assert glb_poses(tmp_path / "blob-poses.glb")[0] == [r["output"].split("#")[1] for r in done]


def test_a_usd_pack_holds_the_poses_as_blend_shapes(inputs, packed, client2, tmp_path, cage):
    """--pack usd: blob-poses.usdc, whose blend shapes UsdSkel computes as the replays; the same
    poses as the .glb (the same settings but the pack)."""
    pytest.importorskip("pxr")
    out = tmp_path / "out"
    result = run([inputs / "blob.obj"], out, settings=pack_settings(cage, pack="usd"), client=client2,
                 progress=False)
    path = out / "blob-poses.usdc"
    assert [r["pack"] for r in rows(result.table)] == ["blob-poses.usdc"] * 3
    rest = he.read_mesh(inputs / "blob.obj").vertices
    names, posed, weights = usd_poses(path, rest)
    assert names == ["pose_000", "pose_001", "pose_002"] and not weights.any()
    diagonal = np.linalg.norm(np.ptp(rest, axis=0))
    for r, pose in zip(rows(result.table), posed):
        assert np.abs(pose - replayed(r, out, tmp_path)).max() <= 1e-6 * diagonal
    assert usd_check(path) == []
    glb, _ = packed  # the same poses as the glTF pack's batch: the same edit files
    assert all((out / r["edit"]).read_bytes() == (glb / r["edit"]).read_bytes() for r in rows(result.table))


def test_pack_options_are_checked(inputs, tmp_path, capsys):
    for arguments, says in ((["--poses", "2", "--pack", "glb", "--format", "ply"], "give --pack"),
                            (["--edits", str(inputs), "--pack", "glb"], "--pack: for --poses only"),
                            (["--poses", "2", "--pack", "fbx"], "invalid choice: 'fbx'")):
        with pytest.raises(SystemExit) if "choice" in says else contextlib.nullcontext():
            status = main(["batch", str(inputs), "-o", str(tmp_path / "o"), *arguments])
            assert status == 2
        assert says in capsys.readouterr().err
    with pytest.raises(ValueError, match="pack must be one of"):
        BatchSettings(poses=1, pack="fbx")
