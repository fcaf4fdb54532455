"""``hybridedit web`` in a real browser: the token, the image, and an edit made with real mouse events.

The server runs as ``python -m hybridedit web`` in a subprocess; headless Chromium drives the
page through selenium. Where the arm is on screen is computed here with the scene's own
camera (the same framing of the same shape at the same canvas size). Without Chromium the tests
are skipped, unless HYBRIDEDIT_REQUIRE_VALIDATORS is set (.ci/run), where that fails.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from shapes import REPO
from support.chromium import drawn_fraction, free_port, need_browser, new_driver, wait

CAGE = "300"  # a small cage: the binding is built in seconds
CANVAS = (1000, 800)  # the browser window; the canvas is what the toolbar leaves


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    need_browser()
    tmp = tmp_path_factory.mktemp("web")
    mesh = tmp / "creature.ply"
    shutil.copy(REPO / "data" / "creature.ply", mesh)  # Save Edit writes beside the mesh
    port = free_port()
    env = dict(os.environ, PYTHONUNBUFFERED="1", PYTHONPATH=str(REPO))
    env.pop("DISPLAY", None)
    proc = subprocess.Popen([sys.executable, "-m", "hybridedit", "web", str(mesh), "--port", str(port),
                             "--cage", CAGE], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=env, cwd=tmp)
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(iter(proc.stdout.readline, "")), daemon=True).start()
    found = wait(lambda: next((m.group(1) for line in list(lines) if (m := re.search(r"(http://\S+)", line))),
                               None) or proc.poll() is not None, 90)
    url = found if isinstance(found, str) else None
    if url is None:
        proc.kill()
        pytest.fail("hybridedit web printed no URL:\n" + "".join(lines))
    assert wait(lambda: _status(f"http://127.0.0.1:{port}/") == 403, 30)
    yield {"url": url, "port": port, "tmp": tmp, "mesh": mesh, "proc": proc, "lines": lines}
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()


def _status(url: str, headers: dict | None = None) -> int | None:
    try:
        return urllib.request.urlopen(urllib.request.Request(url, headers=headers or {}), timeout=5).status
    except urllib.error.HTTPError as e:
        return e.code
    except OSError:
        return None


@pytest.fixture(scope="module")
def driver(server):
    d = new_driver(CANVAS, downloads=server["tmp"])
    yield d
    d.quit()


def test_refused_without_the_token(server):
    port = server["port"]
    for path in ("/", "/index.html", "/ws", "/?secret=wrong"):
        assert _status(f"http://127.0.0.1:{port}{path}") == 403, path
    upgrade = {"Connection": "Upgrade", "Upgrade": "websocket", "Sec-WebSocket-Version": "13",
               "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ=="}
    assert _status(f"http://127.0.0.1:{port}/ws", upgrade) == 403
    assert _status(server["url"]) == 200


def _status_text(d) -> str:
    from selenium.webdriver.common.by import By

    els = d.find_elements(By.ID, "status")
    return els[0].text if els else ""


def test_the_mesh_is_on_the_canvas(server, driver):
    from selenium.webdriver.common.by import By

    d = driver
    d.get(server["url"])
    canvas = wait(lambda: d.find_elements(By.CSS_SELECTOR, "canvas"), 30)[0]
    assert wait(lambda: "vertices" in _status_text(d), 30)
    assert wait(lambda: any("connected" in line for line in list(server["lines"])), 10), server["lines"]
    shot = server["tmp"] / "shot.png"

    def drawn() -> float:
        return drawn_fraction(d, canvas, shot)

    frac = wait(lambda: drawn() > 0.05, 30, 0.5) and drawn()  # (the first image takes a moment)
    assert 0.05 < frac < 0.8, frac


def _camera(server, size):
    """The scene's composite matrix for the shape as the server frames it on a canvas of ``size``."""
    import pyvista as pv

    from hybridedit.fileio.meshfiles import read_mesh
    from hybridedit.fileio.up_axes import up_axis_of
    from hybridedit.viewer.app import _headless_render_window
    from hybridedit.viewer.render.scene import Scene

    mesh = read_mesh(server["mesh"])
    _headless_render_window()
    pl = pv.Plotter(off_screen=True, window_size=list(size))
    try:
        scene = Scene(pl)
        scene.up_axis = up_axis_of(mesh, path=server["mesh"])[0]
        scene.show_preview(mesh.vertices, mesh.faces)
        return mesh, scene.composite_matrix(), scene.display_size()
    finally:
        pl.close()


def _read_ply(path: Path) -> np.ndarray:
    from hybridedit.fileio.meshfiles import read_mesh

    return read_mesh(path).vertices


def _download(d, server, name: str) -> np.ndarray:
    from selenium.webdriver.common.by import By

    out = server["tmp"] / "creature-posed.ply"
    if out.exists():
        out.unlink()
    d.find_element(By.ID, "download").click()
    assert wait(lambda: out.exists() and out.stat().st_size > 1000 and
                 not list(server["tmp"].glob("*.crdownload")), 20)
    time.sleep(0.3)
    return _read_ply(out.rename(server["tmp"] / name))


def test_select_drag_save_and_undo(server, driver):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    from hybridedit.viewer.model.picking import project_points

    d = driver
    canvas = d.find_element(By.CSS_SELECTOR, "canvas")
    r = d.execute_script("return arguments[0].getBoundingClientRect()", canvas)
    w, h = round(r["width"]), round(r["height"])
    mesh, C, size = _camera(server, (w, h))
    assert size == (w, h)
    V = mesh.vertices
    display, front = project_points(V, C, size)
    x = V[:, 0]

    def css(px: float, py: float) -> tuple[int, int]:  # display (origin bottom-left) -> offset from the centre
        return int(round(px - w / 2)), int(round((h - py) - h / 2))

    def rectangle(part: np.ndarray, pad: float) -> None:
        lo, hi = display[part].min(axis=0) - pad, display[part].max(axis=0) + pad
        a, b = css(lo[0], hi[1]), css(hi[0], lo[1])
        ac = ActionChains(d).move_to_element_with_offset(canvas, *a).click_and_hold()
        for k in (1, 2, 3):
            ac.move_to_element_with_offset(canvas, a[0] + (b[0] - a[0]) * k // 3, a[1] + (b[1] - a[1]) * k // 3)
            ac.pause(0.05)
        ac.release().perform()

    def counts():
        m = re.search(r"ROI (\d+), handle (\d+)", _status_text(d))
        return (int(m.group(1)), int(m.group(2))) if m else None

    arm, hand = x > 0.55 * x.max(), x > 0.85 * x.max()  # the arm along +X, its end
    ActionChains(d).send_keys("s").send_keys("r").perform()
    assert wait(lambda: "select, target roi" in _status_text(d), 10), _status_text(d)
    rectangle(arm & front, 8)
    assert wait(lambda: counts() and counts()[0] > 0, 10), _status_text(d)
    ActionChains(d).send_keys("h").perform()
    assert wait(lambda: "target handle" in _status_text(d), 10)
    rectangle(hand & front, 4)
    assert wait(lambda: counts() and counts()[1] > 0, 10), _status_text(d)
    roi, handle = counts()
    assert handle < roi

    rest = _download(d, server, "rest.ply")
    np.testing.assert_array_equal(rest, V)

    ActionChains(d).send_keys("d").perform()
    assert wait(lambda: "; drag, target" in _status_text(d), 10), _status_text(d)
    c = display[hand & front, :2].mean(axis=0)
    start = css(*c)
    ac = ActionChains(d).move_to_element_with_offset(canvas, *start).click_and_hold()
    for k in range(1, 6):
        ac.move_to_element_with_offset(canvas, start[0], start[1] - 12 * k).pause(0.1)
    ac.release().perform()

    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))

    def moved():
        got = _download(d, server, "posed.ply")
        return got if np.abs(got - V).max() > 0.02 * diag else None

    # polished on release, as in the window: the status line says so, and the polish is the pose on display
    assert wait(lambda: "Polished: edge error" in _status_text(d), 60, 0.5), _status_text(d)
    m = re.search(r"edge error ([\d.]+)% -> ([\d.]+)%", _status_text(d))
    assert re.search(r"; frame [\d.]+ ms", _status_text(d)), _status_text(d)  # the engine's time a frame
    assert float(m.group(2)) < float(m.group(1)), _status_text(d)
    posed = wait(moved, 20, 0.5)
    assert posed is not None, _status_text(d)
    assert posed[hand, 1].mean() > V[hand, 1].mean() + 0.02 * diag  # up on screen: +Y up
    body = x < 0.4 * x.max()  # (the ROI reaches into the shoulder: the arm is taken through its thickness)
    assert np.abs(posed[body] - V[body]).max() < 0.01 * diag  # the body stays

    d.find_element(By.ID, "save_edit").click()
    edit = server["mesh"].with_name("creature-edit.json")
    assert wait(lambda: edit.exists() and "Saved the edit" in _status_text(d), 10), _status_text(d)
    out = server["tmp"] / "replayed.ply"
    from hybridedit.cli import main

    assert main(["deform", str(server["mesh"]), "-o", str(out), "--edit", str(edit), "-q"]) == 0
    replayed = _read_ply(out)
    shown = _download(d, server, "saved.ply")  # the pose the edit was saved from (the drag's frames all done)
    # deform writes its .ply in the input's structure: float32 coordinates, as creature.ply has them
    shown32 = shown.astype(np.float32).astype(np.float64)
    assert np.abs(replayed - shown32).max() <= 1e-9 * diag, np.abs(replayed - shown32).max() / diag

    for _ in ("the polish", "the drag"):  # each its own undo step, as in the window
        ActionChains(d).key_down(Keys.CONTROL).send_keys("z").key_up(Keys.CONTROL).perform()
        time.sleep(0.3)
    back = wait(lambda: (lambda got: got if np.array_equal(got, V) else None)(_download(d, server, "undone.ply")),
                 20, 0.5)
    assert back is not None


def test_brush_mirror_and_stretch_map(server, driver):
    """After the edit above (ROI the +X arm, handle its hand, at rest): the brush adds the other arm to the
    ROI in one undo step, Shift+X mirrors the handle so that a drag lifts both hands, and T colours the
    shape by its stretch."""
    from PIL import Image
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    from hybridedit.viewer.model.picking import project_points

    d = driver
    canvas = d.find_element(By.CSS_SELECTOR, "canvas")
    r = d.execute_script("return arguments[0].getBoundingClientRect()", canvas)
    w, h = round(r["width"]), round(r["height"])
    mesh, C, size = _camera(server, (w, h))
    V = mesh.vertices
    display, front = project_points(V, C, size)
    x = V[:, 0]

    def css(px: float, py: float) -> tuple[int, int]:
        return int(round(px - w / 2)), int(round((h - py) - h / 2))

    def counts():
        m = re.search(r"ROI (\d+), handle (\d+)", _status_text(d))
        return (int(m.group(1)), int(m.group(2))) if m else None

    def ctrl_z():
        ActionChains(d).key_down(Keys.CONTROL).send_keys("z").key_up(Keys.CONTROL).perform()

    roi0, handle0 = counts()
    ActionChains(d).send_keys("s").send_keys("b").send_keys("r").perform()
    assert wait(lambda: "select, target roi, brush 30 px" in _status_text(d), 10), _status_text(d)
    ring = d.find_element(By.ID, "brush_ring")  # the brush's outline follows the mouse over the view

    def ring_width() -> float:
        ActionChains(d).move_to_element_with_offset(canvas, 10, 10).move_to_element_with_offset(canvas, 0, 0)\
            .perform()
        return ring.is_displayed() and float(d.execute_script("return arguments[0].offsetWidth", ring))

    assert wait(lambda: ring_width() == 60.0, 10), ring_width()
    ActionChains(d).send_keys("]").perform()
    assert wait(lambda: "brush 38 px" in _status_text(d), 10), _status_text(d)
    assert wait(lambda: abs(ring_width() - 75.0) <= 1.0, 10), ring_width()
    ActionChains(d).send_keys("[").perform()
    assert wait(lambda: "brush 30 px" in _status_text(d), 10), _status_text(d)
    other = (x < 0.55 * x.min()) & front  # the -X arm, seen
    path = display[other][np.argsort(display[other][:, 0])][:, :2]
    points = [css(*p) for p in path[:: max(1, len(path) // 8)]]
    ac = ActionChains(d).key_down(Keys.SHIFT).move_to_element_with_offset(canvas, *points[0]).click_and_hold()
    for p in points[1:]:
        ac.move_to_element_with_offset(canvas, *p).pause(0.05)
    ac.release().key_up(Keys.SHIFT).perform()
    assert wait(lambda: counts()[0] > roi0, 10), _status_text(d)  # Shift adds
    ctrl_z()
    assert wait(lambda: counts() == (roi0, handle0), 10), _status_text(d)  # the stroke: one undo step
    ActionChains(d).key_down(Keys.SHIFT).move_to_element_with_offset(canvas, *points[0]).click_and_hold()\
        .move_to_element_with_offset(canvas, *points[-1]).release().key_up(Keys.SHIFT).perform()
    assert wait(lambda: counts()[0] > roi0, 10), _status_text(d)

    ActionChains(d).key_down(Keys.SHIFT).send_keys("x").key_up(Keys.SHIFT).perform()
    assert wait(lambda: "mirror X" in _status_text(d), 10), _status_text(d)
    ActionChains(d).send_keys("d").perform()
    assert wait(lambda: "; drag, target" in _status_text(d), 10), _status_text(d)
    hand = x > 0.85 * x.max()
    start = css(*display[hand & front, :2].mean(axis=0))
    ac = ActionChains(d).move_to_element_with_offset(canvas, *start).click_and_hold()
    for k in range(1, 6):
        ac.move_to_element_with_offset(canvas, start[0], start[1] - 12 * k).pause(0.1)
    ac.release().perform()
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    assert wait(lambda: "Polished: edge error" in _status_text(d), 60, 0.5), _status_text(d)
    posed = _download(d, server, "mirrored.ply")
    mirrored = x < 0.85 * x.min()
    assert posed[hand, 1].mean() > V[hand, 1].mean() + 0.02 * diag
    assert posed[mirrored, 1].mean() > V[mirrored, 1].mean() + 0.02 * diag  # the other hand follows
    np.testing.assert_allclose(posed[mirrored, 1].mean() - V[mirrored, 1].mean(),
                               posed[hand, 1].mean() - V[hand, 1].mean(), rtol=0.05)

    shot = server["tmp"] / "stretch.png"

    def view() -> np.ndarray:
        drawn_fraction(d, canvas, shot)
        return np.asarray(Image.open(shot).convert("RGB"), dtype=float)

    def colourful(img: np.ndarray) -> float:
        return float((img.max(axis=2) - img.min(axis=2)).mean())

    plain = view()
    ActionChains(d).send_keys("t").perform()
    assert wait(lambda: abs(colourful(view()) - colourful(plain)) > 3.0, 20, 0.5), "T showed no stretch map"
    ActionChains(d).send_keys("t").perform()
    assert wait(lambda: np.abs(view() - plain).mean() < 1.0, 20, 0.5), "T again did not hide it"


def test_pose_turns_a_limb_about_its_joint(server, driver):
    """P, then a drag on the creature's -X hand: the limb becomes the selection and turns up about its
    joint, the body stays; one Ctrl+Z after the polish undoes the polish, the next the turn."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    from hybridedit.viewer.model.picking import project_points

    d = driver
    if "mirror X" in _status_text(d):
        ActionChains(d).key_down(Keys.SHIFT).send_keys("x").key_up(Keys.SHIFT).perform()
        assert wait(lambda: "mirror X" not in _status_text(d), 10), _status_text(d)
    canvas = d.find_element(By.CSS_SELECTOR, "canvas")
    r = d.execute_script("return arguments[0].getBoundingClientRect()", canvas)
    w, h = round(r["width"]), round(r["height"])
    mesh, C, size = _camera(server, (w, h))
    V = mesh.vertices
    x = V[:, 0]
    before = _download(d, server, "before-pose.ply")  # (the pose the test above left: both hands up)
    display, front = project_points(before, C, size)
    ActionChains(d).send_keys("p").perform()
    assert wait(lambda: "; pose, target" in _status_text(d), 10), _status_text(d)
    hand = x < 0.8 * x.min()
    c = display[hand & front, :2].mean(axis=0)
    start = int(round(c[0] - w / 2)), int(round((h - c[1]) - h / 2))
    from PIL import Image

    shot = server["tmp"] / "hover.png"

    def view() -> np.ndarray:
        drawn_fraction(d, canvas, shot)
        return np.asarray(Image.open(shot).convert("RGB"), dtype=float)

    ActionChains(d).move_to_element_with_offset(canvas, -w // 2 + 5, -h // 2 + 5).perform()  # off the shape
    time.sleep(0.5)
    still = view()
    ActionChains(d).move_to_element_with_offset(canvas, start[0] + 3, start[1]).pause(0.2)\
        .move_to_element_with_offset(canvas, *start).perform()  # hovering the limb shows it and its joint
    assert wait(lambda: np.abs(view() - still).mean() > 0.05, 10, 0.5), "hovering a limb showed nothing"
    ac = ActionChains(d).move_to_element_with_offset(canvas, *start).click_and_hold()
    for k in range(1, 6):
        ac.move_to_element_with_offset(canvas, start[0], start[1] - 12 * k).pause(0.1)
    ac.release().perform()
    assert wait(lambda: "Polished: edge error" in _status_text(d), 60, 0.5), _status_text(d)
    posed = _download(d, server, "limb-posed.ply")
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    assert posed[hand, 1].mean() > before[hand, 1].mean() + 0.02 * diag, _status_text(d)
    body = np.abs(x) < 0.3 * x.max()
    assert np.abs(posed[body] - before[body]).max() < 0.01 * diag
    for _ in range(2):
        ActionChains(d).key_down(Keys.CONTROL).send_keys("z").key_up(Keys.CONTROL).perform()
        time.sleep(0.3)
    assert wait(lambda: np.array_equal(_download(d, server, "unposed.ply"), before), 20, 0.5)


def test_save_writes_on_the_server_in_the_meshs_folder_only(server, driver):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    d = driver
    field = d.find_element(By.CSS_SELECTOR, "#save_name input, input#save_name")
    assert field.get_attribute("value") == "creature-posed.ply"
    shown = _download(d, server, "shown-for-save.ply")

    def save_as(name: str) -> None:
        field.send_keys(Keys.CONTROL, "a")
        field.send_keys(Keys.BACKSPACE)
        field.send_keys(name)
        time.sleep(0.5)  # (the name reaches the server)
        d.find_element(By.ID, "save").click()

    save_as("../escaped.ply")
    assert wait(lambda: "Not saved: ../escaped.ply: not in the mesh's folder" in _status_text(d), 10), _status_text(d)
    assert not (server["tmp"].parent / "escaped.ply").exists()
    save_as("kept.obj")
    out = server["tmp"] / "kept.obj"
    assert wait(lambda: out.exists() and "Saved the posed mesh" in _status_text(d), 10), _status_text(d)
    got = _read_ply(out)  # (read_mesh reads any format)
    assert np.abs(got - shown).max() <= 1e-6 * np.ptp(shown, axis=0).max()
