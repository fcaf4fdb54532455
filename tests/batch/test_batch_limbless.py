"""Poses of shapes without limbs (a skull, a ball, a bowl): bends, twists and tapers of the main axis
that move the shape, and the manifest's ``moved`` column saying how far."""

from __future__ import annotations

import numpy as np
import pyarrow.parquet as pq
import pytest

import hybridedit as he
from hybridedit.batching.tasks import moved_percent
from hybridedit.cli import main

from shapes import bowl, icosphere, skull_like


@pytest.fixture(scope="module")
def round_shapes(tmp_path_factory):
    folder = tmp_path_factory.mktemp("limbless")
    he.write_mesh(folder / "skull.ply", skull_like(3))
    he.write_mesh(folder / "ball.ply", icosphere(3))
    he.write_mesh(folder / "bowl.ply", bowl(3))
    return folder


@pytest.fixture(scope="module")
def posed_round(round_shapes, client2, tmp_path_factory, cage):
    out = tmp_path_factory.mktemp("limbless-out")
    table = he.batch([round_shapes], out, poses=4, seed=5, client=client2, cage_size=cage, progress=False)
    return out, table


def test_every_pose_of_a_shape_without_limbs_moves_it_2_percent(posed_round):
    """Each pose is a bend, twist or taper of the main axis: an end held (not moved at all), the other
    turned or scaled; it moves the shape at least 2% of its diagonal, as its row says."""
    out, table = posed_round
    rows = table.to_pylist()
    assert len(rows) == 12 and {r["input"].rsplit("/", 1)[1] for r in rows} == {"skull.ply", "ball.ply", "bowl.ply"}
    for r in rows:
        assert r["status"] == "done", r["message"]
        rest, posed = he.read_mesh(r["input"]), he.read_mesh(out / r["output"])
        assert r["moved"] >= 2.0 and r["moved"] == pytest.approx(moved_percent(rest.vertices, posed.vertices))
        assert r["max_stretch"] <= 50.0
        held, moving = he.load_edit(out / r["edit"]).handles
        assert held.rotate is None and held.matrix is None and not held.translate.any()
        assert np.array_equal(posed.vertices[held.indices], rest.vertices[held.indices])
        assert (moving.rotate is None) != (moving.matrix is None)  # turned, or tapered by a matrix
    on_disk = pq.read_table(out / "manifest.parquet")
    assert sorted(on_disk.column("moved").to_pylist()) == sorted(r["moved"] for r in rows)


def test_a_pose_of_a_bowl_replays_with_hybridedit_deform(posed_round, tmp_path):
    out, table = posed_round
    r = next(r for r in table.to_pylist() if r["input"].endswith("bowl.ply"))
    again = tmp_path / "again.ply"
    assert main(["deform", r["input"], "-o", str(again), "--edit", str(out / r["edit"]), "-q"]) == 0
    assert again.read_bytes() == (out / r["output"]).read_bytes()
