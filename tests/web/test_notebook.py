"""``he.widget`` in a notebook run by nbclient: the cell's view in a real browser, posed from Python.

The notebook runs in an IPython kernel of this interpreter (a kernel spec made here, so the
test needs no Jupyter installation). Between its cells the kernel is idle and serves the
editor (trame on the kernel's event loop), and headless Chromium opens the view as a
notebook shows it: the cell's iframe inside a page of another site.
"""

from __future__ import annotations

import http.server
import json
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from shapes import REPO
from support.chromium import drawn_fraction, free_port, need_browser, new_driver, wait

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

KERNEL = "hybridedit-test"


def _kernel_spec(folder: Path) -> Path:
    """A kernel spec for this interpreter under ``folder`` (a JUPYTER_PATH entry)."""
    spec = folder / "kernels" / KERNEL
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "hybridedit tests", "language": "python"}))
    return folder


def _text(cell) -> str:
    return "".join(o.get("text", "") for o in cell.outputs if o.get("output_type") == "stream")


def _html(cell) -> str:
    return "".join(o.get("data", {}).get("text/html", "") for o in cell.outputs
                   if o.get("output_type") in ("display_data", "execute_result"))


def _errors(nb) -> list[str]:
    return ["\n".join(o.get("traceback", [])) for c in nb.cells for o in c.get("outputs", [])
            if o.get("output_type") == "error"]


@pytest.fixture
def framing_site(tmp_path):
    """A page server on ``localhost`` (another site than the editor's 127.0.0.1), as a notebook is."""
    folder = tmp_path / "site"
    folder.mkdir()
    port = free_port()

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def __init__(self, *a, **k):
            super().__init__(*a, directory=str(folder), **k)

        def log_message(self, *a):
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", port), Quiet)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    yield folder, f"http://localhost:{port}"
    httpd.shutdown()


def test_a_notebook_poses_the_widget_by_hand_and_by_code(tmp_path, monkeypatch, framing_site):
    need_browser()
    monkeypatch.setenv("JUPYTER_PATH", str(_kernel_spec(tmp_path / "jupyter")))
    monkeypatch.setenv("PYTHONPATH", str(REPO))
    monkeypatch.delenv("DISPLAY", raising=False)  # (the kernel renders off-screen, as on a server)
    out, edit = tmp_path / "posed.ply", tmp_path / "pose-edit.json"
    mesh = REPO / "data" / "creature.ply"
    cells = [
        f"import json\nimport numpy as np\nimport hybridedit as he\n"
        f"w = he.widget({str(mesh)!r}, cage_size=300, height=500)\nw",
        "await w.ready\nprint(w.url)",
        "rest = w.pose\nx = rest[:, 0]\nw.select(roi=x > 0.45, handle=x > 0.85)\nposed = w.move([0.0, 0.2, 0.0])\n"
        "d = np.linalg.norm(posed - rest, axis=1)\n"
        "print(json.dumps({'hand': float(d[x > 0.85].min()), 'body': float(d[x < 0.2].max())}))\n"
        f"w.save({str(out)!r})\nw.save_edit({str(edit)!r})",
        "print(json.dumps({'undone': w.undo(), 'at_rest': bool(np.array_equal(w.pose, rest))}))",
        "await w.close()",
    ]
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells])
    client = nbclient.NotebookClient(nb, kernel_name=KERNEL, timeout=300, resources={"metadata": {"path": str(tmp_path)}})
    site_folder, site = framing_site
    with client.setup_kernel():
        for i in (0, 1):
            client.execute_cell(nb.cells[i], i)
        url = _text(nb.cells[1]).strip()
        assert url.startswith("http://127.0.0.1:") and "secret=" in url, url
        frame = _html(nb.cells[0])  # shown before the server listened: a page that opens the view once it does
        assert frame.startswith("<iframe") and "starting the editor" in frame and url in frame, frame

        from selenium.webdriver.common.by import By

        d = new_driver((900, 700))
        try:
            (site_folder / "notebook.html").write_text(f"<html><body><h3>a notebook</h3>{frame}</body></html>")
            d.get(f"{site}/notebook.html")  # the cell's iframe inside another site's page
            iframe = wait(lambda: d.find_elements(By.TAG_NAME, "iframe"), 20)[0]
            shot = tmp_path / "shot.png"
            steady = []

            def drawn_and_steady() -> bool:
                """The view shows the shape and its image stopped changing (the page and its first image)."""
                steady.append(drawn_fraction(d, iframe, shot))
                return len(steady) > 1 and steady[-1] > 0.1 and abs(steady[-1] - steady[-2]) < 0.003

            assert wait(drawn_and_steady, 60, 0.5), f"the cell's view shows no shape: {steady}"
            before = steady[-1]

            from PIL import Image

            def view() -> np.ndarray:
                drawn_fraction(d, iframe, shot)
                return np.asarray(Image.open(shot).convert("L"), dtype=float)

            def steady_view(timeout: float = 20.0) -> np.ndarray:
                """The view once its image stopped changing (a cell's selection and its move each send one)."""
                seen = [view()]

                def still() -> bool:
                    time.sleep(0.4)
                    seen.append(view())
                    return np.abs(seen[-1] - seen[-2]).mean() < 0.003

                assert wait(still, timeout, 0.0), "the view kept changing"
                return seen[-1]

            rest_view = steady_view()
            client.execute_cell(nb.cells[2], 2)  # posed from Python while the view is open
            got = json.loads(_text(nb.cells[2]))
            assert got["hand"] > 0.15 and got["body"] < 1e-9, got
            # the view follows Python's pose (the image comes a moment after the cell)
            assert wait(lambda: np.abs(view() - rest_view).mean() > 0.05, 20, 0.5), "the view did not follow the move"
            posed_view = steady_view()
            client.execute_cell(nb.cells[3], 3)
            assert json.loads(_text(nb.cells[3])) == {"undone": True, "at_rest": True}
            assert wait(lambda: np.abs(view() - posed_view).mean() > 0.05, 20, 0.5), "the view did not follow the undo"
            assert abs(drawn_fraction(d, iframe, shot) - before) < 0.02

            d.get(url.replace("secret=", "secret=wrong"))  # the page is trame's; the session is not
            canvases = wait(lambda: d.find_elements(By.CSS_SELECTOR, "canvas"), 10)
            time.sleep(4)
            assert not canvases or drawn_fraction(d, canvases[0], shot) < 0.01, "a view without the token"
        finally:
            d.quit()
        client.execute_cell(nb.cells[4], 4)
    assert not _errors(nb), _errors(nb)

    # what the notebook saved is what `hybridedit deform` replays from its edit
    from hybridedit.cli import main
    from hybridedit.fileio.meshfiles import read_mesh

    replayed = tmp_path / "replayed.ply"
    assert main(["deform", str(mesh), "-o", str(replayed), "--edit", str(edit), "-q"]) == 0
    saved = read_mesh(out).vertices
    assert np.abs(read_mesh(replayed).vertices - saved).max() <= 1e-9 * np.ptp(saved, axis=0).max()


def test_the_widget_needs_a_running_event_loop():
    """Outside a kernel (no event loop runs) he.widget says where the editor is instead."""
    import hybridedit as he

    with pytest.raises(RuntimeError, match="running event loop.*hybridedit web"):
        he.widget(REPO / "data" / "creature.ply")
