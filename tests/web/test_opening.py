"""``hybridedit web`` opens a shape behind a page that shows the build: the shape as soon as it is read,
the stage and percentage, Cancel, and Open Again; then the editor on it, with an edit replayed. Driven
in-process on an event loop (the build held at a gate, as the window's tests hold theirs)."""

from __future__ import annotations

import asyncio
import threading
import time

import numpy as np
import pytest

pytest.importorskip("trame")

import hybridedit as he  # noqa: E402
from hybridedit.viewer.model import building  # noqa: E402
from hybridedit.web.editor_app import WebEditor  # noqa: E402
from shapes import REPO, icosphere  # noqa: E402


@pytest.fixture
def gate(monkeypatch) -> threading.Event:
    """The build reports "binding" and waits there until the gate is set (a cancel stops it)."""
    real = building.build_rig
    gate = threading.Event()

    def build_rig(mesh, *, cage_size, cache, progress):
        progress("building the cage", 0.5)
        time.sleep(0.06)
        while not gate.wait(0.02):
            progress("binding", 0.25)  # raises Cancelled once cancelled
        return real(mesh, cage_size=cage_size, cache=cache, progress=progress)

    monkeypatch.setattr(building, "build_rig", build_rig)
    yield gate
    gate.set()


async def _until(pred, timeout: float = 30.0) -> None:
    t0 = time.perf_counter()
    while not pred():
        assert time.perf_counter() - t0 < timeout, "timed out"
        await asyncio.sleep(0.02)


def test_the_page_shows_the_build_and_cancel_and_open_again_work(gate, tmp_path):
    mesh = icosphere(3)
    path = tmp_path / "ball.ply"
    he.write_mesh(path, mesh)

    async def scenario():
        web = WebEditor(None, "token", name=path.name)
        st = web.state
        assert st.building and web.session is None
        web.on_hotkey("s")  # (no shape yet: the keys do nothing)
        web.open_file(path, mesh=he.read_mesh(path), cage_size=60)
        await _until(lambda: st.build_stage == "binding")
        assert st.building and 0 < st.build_percent < 100 and "binding" in st.status
        web.cancel_build()
        await _until(lambda: st.build_failed)
        assert st.build_failed == "The build was cancelled" and web.session is None and st.building
        gate.set()
        web.open_again()
        await _until(lambda: web.session is not None)
        assert not st.building and not st.build_failed and "vertices, cage" in st.status
        s = web.session
        assert s.mesh.n_vertices == mesh.n_vertices and s.path == path
        web.plotter.close()

    asyncio.run(scenario())


def test_an_edit_is_replayed_once_built_and_a_bad_one_is_said(tmp_path):
    """--edit: the pose of the edit once the shape is built; an edit of another shape is said, not fatal."""
    import trimesh

    mesh = icosphere(3)
    path = tmp_path / "ball.ply"
    he.write_mesh(path, mesh)
    ed = he.HybridEditor(mesh, 60)
    x = mesh.vertices[:, 0]
    ed.set_selection(np.flatnonzero(x > 0.7), roi=np.flatnonzero(x > 0.0))
    posed = ed.pose(translate=[0.0, 0.3, 0.0])
    edit = ed.edit

    async def scenario(the_edit, cage=60):
        web = WebEditor(None, "token", name=path.name)
        web.open_file(path, mesh=he.read_mesh(path), cage_size=cage, edit=the_edit, edit_path="e.json")
        await _until(lambda: web.session is not None)
        out = web.session.shown_positions.copy(), web.gestures.message
        web.plotter.close()
        return out

    shown, message = asyncio.run(scenario(edit))
    np.testing.assert_allclose(shown, posed, atol=1e-9)
    assert message == ""
    other = trimesh.creation.icosphere(2)
    ed2 = he.HybridEditor(he.Mesh(other.vertices, other.faces), 40)
    ed2.set_selection(np.arange(5), roi=np.arange(40))
    ed2.pose(translate=[0.0, 0.1, 0.0])
    shown, message = asyncio.run(scenario(ed2.edit))
    np.testing.assert_array_equal(shown, mesh.vertices)
    assert "was not replayed" in message, message
