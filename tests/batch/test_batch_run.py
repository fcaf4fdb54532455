"""hybridedit batch on a two-worker LocalCluster: valid outputs, replay, determinism, resume,
failures, the command's exit statuses, and workers free of Qt and VTK."""

from __future__ import annotations

import shutil
import sys

import numpy as np
import pyarrow.parquet as pq
import pytest

import hybridedit as he
from hybridedit.batching.api import run
from hybridedit.cli import main


def rows(table) -> list[dict]:
    return table.to_pylist()


def test_outputs_are_posed_copies_of_their_inputs(inputs, posed, client2):
    """Each output has its input's topology, is moved, and its row records its edge error."""
    out, table = posed
    assert table.num_rows == 6
    assert [r["output"] for r in rows(table)] == [f"{s}-pose00{k}.ply" for s in ("blob", "long") for k in range(3)]
    for r in rows(table):
        assert r["status"] == "done", r["message"]
        src = he.read_mesh(r["input"])
        got = he.read_mesh(out / r["output"])
        assert np.array_equal(got.faces, src.faces)
        moved = np.linalg.norm(got.vertices - src.vertices, axis=1)
        assert moved.max() > 0.01 * src.bbox_diagonal()  # posed
        assert (moved == 0).any()  # outside the regions, nothing moved
        assert 0 < r["edge_error"] <= r["max_stretch"] <= 50.0
        assert r["edge_error"] == pytest.approx(he.rrms_edge_error(src.vertices, got.vertices, src.edges()))
        assert 1 <= r["draws"] <= 8 and r["seed"] == 11 and r["worker"].startswith("tcp://")
        assert len(r["input_sha256"]) == len(r["output_sha256"]) == len(r["edit_sha256"]) == 64
    assert {r["worker"] for r in rows(table)} <= set(client2.scheduler_info()["workers"])


def test_the_manifest_on_disk_is_the_table(posed):
    out, table = posed
    on_disk = pq.read_table(out / "manifest.parquet")
    assert on_disk.schema == table.schema
    assert sorted(rows(on_disk), key=lambda r: r["output"]) == rows(table)
    assert not (out / ".manifest.journal.jsonl").exists()  # folded into the Parquet file at the end


def test_replaying_an_outputs_edit_makes_the_same_file(posed, tmp_path, cage):
    """hybridedit deform MESH --edit EDIT writes the output byte for byte (binary PLY: lossless)."""
    out, table = posed
    for r in rows(table)[::2]:
        again = tmp_path / f"again-{r['pose']}.ply"
        assert main(["deform", r["input"], "-o", str(again), "--edit", str(out / r["edit"]), "-q"]) == 0
        assert again.read_bytes() == (out / r["output"]).read_bytes(), r["output"]
        edit = he.load_edit(out / r["edit"])
        assert edit.iterations == 60 and edit.cage["size"] == cage and edit.space == "shape"
        assert all(within_45_degrees(h) for h in edit.handles)


def within_45_degrees(group) -> bool:
    """A handle group of a batch pose: a limb or an end of the main axis turned by at most 45 degrees,
    an end held (no transform) or tapered by at most 40% (the scale a 45-degree taper draws)."""
    if group.rotate is not None:
        return abs(group.rotate["degrees"]) <= 45
    scales = np.linalg.svd(group.transform()[:3, :3], compute_uv=False)
    return bool(np.all(np.abs(scales - 1) <= 0.4 + 1e-12))


@pytest.mark.slow
def test_the_same_seed_makes_the_same_files_with_one_worker(inputs, posed, tmp_path, cage):
    """One worker, inputs given in the other order: the same bytes as two workers made."""
    out, table = posed
    one = he.batch([inputs / "long.ply", inputs / "blob.obj"], tmp_path, poses=3, seed=11, workers=1,
                   cage_size=cage, output_format="ply", progress=False)
    assert len({r["worker"] for r in rows(one)}) == 1
    mine = {r["output"]: r["output_sha256"] for r in rows(one)}
    assert mine == {r["output"]: r["output_sha256"] for r in rows(table)}
    other = he.batch([inputs / "blob.obj"], tmp_path / "seed12", poses=1, seed=12, workers=1,
                     cage_size=cage, output_format="ply", progress=False)
    assert rows(other)[0]["output_sha256"] != mine["blob-pose000.ply"]


def test_a_rerun_skips_what_is_done_and_redoes_the_rest(inputs, posed, client2, tmp_path, cage):
    out, _ = posed
    folder = tmp_path / "out"
    shutil.copytree(out, folder)
    before = {r["output"]: r for r in rows(pq.read_table(folder / "manifest.parquet"))}
    (folder / "blob-pose001.ply").unlink()  # lost
    spoiled = folder / "long-pose002.ply"
    spoiled.write_bytes(spoiled.read_bytes()[:-8] + b"\0" * 8)  # changed: its hash no longer matches
    result = run([inputs], folder, settings=settings(cage), client=client2, progress=False)
    assert (result.made, result.skipped, result.failed) == (2, 4, 0)
    after = {r["output"]: r for r in rows(result.table)}
    remade = {k for k in after if after[k]["finished"] != before[k]["finished"]}
    assert remade == {"blob-pose001.ply", "long-pose002.ply"}
    assert after["long-pose002.ply"]["output_sha256"] == before["long-pose002.ply"]["output_sha256"]
    # other arguments (another seed) are another batch: nothing is skipped
    again = run([inputs], folder, settings=settings(cage, seed=12), client=client2, progress=False)
    assert again.skipped == 0 and again.made == 6


def settings(cage, **kw):
    from hybridedit.batching.settings import BatchSettings

    return BatchSettings(**{"poses": 3, "seed": 11, "cage_size": cage, "output_format": ".ply", **kw})


def test_a_corrupt_input_is_a_failed_row_and_the_others_are_made(inputs, client2, tmp_path, capsys, cage):
    src = tmp_path / "in"
    shutil.copytree(inputs, src)
    (src / "broken.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    address = client2.scheduler.address
    status = main(["batch", str(src), "-o", str(tmp_path / "out"), "--poses", "1", "--cage", str(cage),
                 "--scheduler", address])
    err = capsys.readouterr().err
    assert status == 1  # something failed
    table = pq.read_table(tmp_path / "out" / "manifest.parquet")
    by = {r["output"]: r for r in rows(table)}
    assert by["broken-pose000.obj"]["status"] == "failed"
    assert "broken.obj" in by["broken-pose000.obj"]["message"] and "\n" not in by["broken-pose000.obj"]["message"]
    assert by["blob-pose000.obj"]["status"] == by["long-pose000.ply"]["status"] == "done"
    assert "hybridedit: failed: broken-pose000.obj: broken.obj" in err
    assert "1 failed" in err and "Traceback" not in err
    # all done: exit status 0, and nothing made again
    (src / "broken.obj").unlink()
    assert main(["batch", str(src), "-o", str(tmp_path / "out"), "--poses", "1", "--cage", str(cage),
                 "--scheduler", address]) == 0
    assert "0 made, 2 done before, 0 failed" in capsys.readouterr().err


@pytest.mark.parametrize("arguments, says", [
    (["--poses", "2", "--edits", "x"], "give --poses N"),
    (["--poses", "0"], "--poses must be a whole number >= 1"),
    (["--poses", "2", "--max-stretch", "-3"], "--max-stretch must be a number"),
    (["--poses", "2", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "not both"),
    (["--edits", "EDITS", "--seed", "3"], "--seed: for --poses only"),
    (["--poses", "2", "--format", "xyz"], "--format must be one of"),
])
def test_bad_arguments_are_one_line_and_exit_2(inputs, tmp_path, capsys, arguments, says):
    arguments = [a.replace("EDITS", str(inputs)) for a in arguments]
    assert main(["batch", str(inputs), "-o", str(tmp_path / "o"), *arguments]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("hybridedit: error: ") and says in err and len(err.splitlines()) == 1


def test_an_input_that_names_nothing_exits_2(tmp_path, capsys):
    assert main(["batch", str(tmp_path / "nothing.obj"), "-o", str(tmp_path / "o"), "--poses", "1"]) == 2
    assert capsys.readouterr().err.strip() == f"hybridedit: error: {tmp_path / 'nothing.obj'}: no such file or folder"


def test_edit_files_given_per_mesh(inputs, posed, client2, tmp_path):
    """--edits: each mesh replays the edit file named like it, which is copied beside its output; a
    mesh without one is a failed row."""
    out, _ = posed
    edits = tmp_path / "edits"
    edits.mkdir()
    shutil.copy(out / "blob-pose002.edit.json", edits / "blob.json")
    table = he.batch([inputs], tmp_path / "replayed", edits=edits, client=client2, output_format="ply",
                     progress=False)
    by = {r["output"]: r for r in rows(table)}
    assert by["blob.ply"]["status"] == "done" and by["blob.ply"]["pose"] is None
    assert (tmp_path / "replayed" / "blob.ply").read_bytes() == (out / "blob-pose002.ply").read_bytes()
    assert (tmp_path / "replayed" / "blob.edit.json").read_bytes() == (edits / "blob.json").read_bytes()
    assert by["long.ply"]["status"] == "failed" and "no edit file" in by["long.ply"]["message"]


def test_workers_import_neither_qt_nor_vtk(posed, client2):
    def gui_modules():
        return sorted(m for m in sys.modules if m.split(".")[0] in ("PySide6", "vtk", "vtkmodules", "pyvista",
                                                                     "pyvistaqt", "PyQt5", "PyQt6"))

    assert "hybridedit.batching.tasks" in client2.run(lambda: sorted(sys.modules)).popitem()[1]
    assert all(mods == [] for mods in client2.run(gui_modules).values())
