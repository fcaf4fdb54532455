"""Frames the browser shows per second while dragging in ``hybridedit web``, beside the window's.

    python benchmarks/web_fps.py [MESH] [--seconds 4] [--rounds 3] [--size 1280x900]
    python benchmarks/web_fps.py --smoke        (a small generated mesh, a second a side)

The browser side: ``hybridedit web MESH --edit E`` in a subprocess (E selects the top 5% of
the shape along its longest axis as the handle and the top 30% as the region, as
``window_fps.py`` does), headless Chromium (selenium) with a window of ``--size``, Drag
mode, and the left button held down while the pointer circles over the view at 125 Hz
(W3C pointer actions, real mouse events). A frame counts when the page has decoded and
shown an image the server sent (an image element's ``load``); the rate is the cadence
from a slice's first frame to its last.

The window side: ``benchmarks/window_fps.py MESH --seconds S --size WxH`` (the real window,
real Qt events, polish off as here), in turns with the browser, ``--rounds`` times each, so
both see the same machine load. The browser's window is sized so that its view has the
window's view's pixels. Prints each round and last the line

    web_fps: <file> <n_vertices> browser_fps=<median> window_fps=<median> ratio=<browser/window>
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))  # the browser helpers of tests/web
sys.path.insert(0, str(ROOT / "benchmarks"))

from window_fps import parse_size, smoke_mesh, top_fraction  # noqa: E402

#: counts the images the page has shown (load events of image elements), from the page's first script
COUNT_FRAMES = """window.__frames = [];
document.addEventListener('load', (e) => {
  if (e.target && e.target.tagName === 'IMG') window.__frames.push(performance.now());
}, true);"""


def write_edit(mesh: Path, folder: Path) -> Path:
    """The selection of ``window_fps.py`` as an edit file (no move): handle the top 5%, region the top 30%."""
    from hybridedit.fileio.meshfiles import read_mesh

    V = read_mesh(mesh).vertices
    path = folder / "select.json"
    path.write_text(json.dumps({"handle": top_fraction(V, 0.05).tolist(), "roi": top_fraction(V, 0.30).tolist(),
                                "translate": [0.0, 0.0, 0.0]}))
    return path


class WebServer:
    """``hybridedit web`` in a subprocess (off-screen: no DISPLAY), until :meth:`close`."""

    def __init__(self, mesh: Path, edit: Path, cage: float) -> None:
        from support.chromium import free_port

        self.port = free_port()
        env = dict(os.environ, PYTHONUNBUFFERED="1", PYTHONPATH=str(ROOT))
        env.pop("DISPLAY", None)
        self.proc = subprocess.Popen([sys.executable, "-m", "hybridedit", "web", str(mesh), "--port", str(self.port),
                                      "--cage", str(cage), "--edit", str(edit)],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
        self.lines: list[str] = []
        threading.Thread(target=lambda: self.lines.extend(iter(self.proc.stdout.readline, "")), daemon=True).start()
        t0 = time.time()
        self.url = None
        while self.url is None:
            found = [m.group(1) for line in list(self.lines) if (m := re.search(r"(http://\S+)", line))]
            self.url = found[0] if found else None
            if self.proc.poll() is not None or time.time() - t0 > 900:
                raise SystemExit("web_fps: hybridedit web did not start:\n" + "".join(self.lines))
            time.sleep(0.2)

    def close(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


class Browser:
    """Headless Chromium on the editor's page, in Drag mode."""

    def __init__(self, url: str, size: tuple[int, int]) -> None:
        from selenium.webdriver.common.by import By

        from support.chromium import drawn_fraction, new_driver, wait

        self.d = d = new_driver(size)
        d.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": COUNT_FRAMES})
        d.get(url)
        self.canvas = wait(lambda: d.find_elements(By.CSS_SELECTOR, "canvas"), 60)[0]
        shot = Path(tempfile.mkdtemp(prefix="web_fps-")) / "shot.png"
        if not wait(lambda: drawn_fraction(d, self.canvas, shot) > 0.03, 60, 0.5):
            raise SystemExit("web_fps: the browser shows no shape")
        d.find_element(By.ID, "mode_drag").click()
        if not wait(lambda: "drag" in d.find_element(By.ID, "status").text, 20):
            raise SystemExit("web_fps: the page did not go into Drag mode")
        self._measure()
        self.phase = 0.0
        self.held = False

    def _measure(self) -> None:
        r = self.d.execute_script("return arguments[0].getBoundingClientRect()", self.canvas)
        self.box = (r["left"], r["top"], r["width"], r["height"])

    def fit_view(self, size: tuple[int, int]) -> None:
        """Resize the browser's window until its view (the canvas) has ``size`` pixels, the window's."""
        for _ in range(4):
            self._measure()
            dw, dh = size[0] - round(self.box[2]), size[1] - round(self.box[3])
            if dw == 0 and dh == 0:
                break
            w = self.d.get_window_size()
            self.d.set_window_size(w["width"] + dw, w["height"] + dh)
            time.sleep(1.0)  # (the page lays out, the server renders at the new size)

    def _actions(self):
        from selenium.webdriver.common.actions.action_builder import ActionBuilder
        from selenium.webdriver.common.actions.pointer_input import PointerInput

        mouse = PointerInput("mouse", "mouse")
        return ActionBuilder(self.d, mouse=mouse, duration=8), mouse

    def _point(self) -> tuple[int, int]:
        left, top, w, h = self.box
        c = (left + 0.3 * w, top + 0.5 * h)
        radius = 0.08 * h
        return int(c[0] + radius * np.sin(self.phase)), int(c[1] + radius * (1.0 - np.cos(self.phase)))

    def drag_slice(self, seconds: float) -> tuple[int, float]:
        """Circle with the button down for ``seconds``; returns (frame intervals, their seconds)."""
        builder, _ = self._actions()
        if not self.held:
            builder.pointer_action.move_to_location(*self._point())
            builder.pointer_action.pointer_down()
            self.held = True
        for _ in range(int(seconds / 0.008)):
            self.phase += 0.05
            builder.pointer_action.move_to_location(*self._point())
        self.d.execute_script("window.__frames = []")
        builder.perform()
        time.sleep(0.3)  # (the image of the last move)
        got = self.d.execute_script("return window.__frames")
        if len(got) < 2:
            return 0, 0.0
        return len(got) - 1, (got[-1] - got[0]) / 1e3

    def close(self) -> None:
        if self.held:
            builder, _ = self._actions()
            builder.pointer_action.pointer_up()
            builder.perform()
        self.d.quit()


def window_fps(mesh: Path, seconds: float, size: tuple[int, int], cage: float) -> tuple[float, str]:
    """The window's displayed frames per second (``window_fps.py``, in a subprocess); and its view line."""
    out = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "window_fps.py"), str(mesh), "--seconds",
                          str(seconds), "--size", f"{size[0]}x{size[1]}", "--cage", str(cage)],
                         capture_output=True, text=True, cwd=ROOT)
    m = re.search(r"displayed_fps=([\d.]+)", out.stdout)
    if m is None:
        raise SystemExit("web_fps: window_fps.py printed no rate:\n" + out.stdout + out.stderr)
    view = next((line for line in out.stdout.splitlines() if line.startswith("view ")), "")
    return float(m.group(1)), view


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh", nargs="?", help="mesh file (default: data/creature.ply)")
    ap.add_argument("--seconds", type=float, default=4.0, help="drag time a round, each side (default 4)")
    ap.add_argument("--rounds", type=int, default=3, help="turns each side takes (default 3)")
    ap.add_argument("--cage", type=float, default=0.05, help="cage size as a fraction (default 0.05)")
    ap.add_argument("--size", type=parse_size, default=(1280, 900), help="browser and window size, WxH")
    ap.add_argument("--smoke", action="store_true", help="a quick run on a small generated mesh")
    args = ap.parse_args(argv)
    from support.chromium import CHROMEDRIVER, CHROMIUM

    if CHROMIUM is None or not os.path.exists(CHROMEDRIVER):
        print("web_fps: Chromium or chromedriver is not installed (scripts/setup.sh test installs them)",
              file=sys.stderr)
        return 2
    if args.smoke:
        mesh, seconds, rounds = smoke_mesh(), 1.0, 1
    else:
        mesh, seconds, rounds = Path(args.mesh or ROOT / "data" / "creature.ply"), args.seconds, args.rounds
    if not mesh.is_file():
        print(f"web_fps: {mesh}: no such file", file=sys.stderr)
        return 2
    from hybridedit.fileio.meshfiles import read_mesh

    n = read_mesh(mesh).n_vertices
    folder = Path(tempfile.mkdtemp(prefix="web_fps-"))
    _, view = window_fps(mesh, 1.0, args.size, args.cage)  # (warm-up; its view's size is the browser's)
    m = re.search(r"view (\d+)x(\d+) px", view)
    server = WebServer(mesh, write_edit(mesh, folder), args.cage)
    try:
        browser = Browser(server.url, args.size)
        try:
            if m is not None:
                browser.fit_view((int(m.group(1)), int(m.group(2))))
            browser.drag_slice(min(1.0, seconds))  # warm-up
            left, top, w, h = browser.box
            print(f"browser view {round(w)}x{round(h)} px, {n:,} vertices, {rounds} rounds of {seconds:.1f} s a side")
            print(f"{'round':>5} {'browser fps':>12} {'window fps':>11}")
            web, win, view = [], [], ""
            for k in range(rounds):
                frames, dt = browser.drag_slice(seconds)
                web.append(frames / dt if dt > 0 else 0.0)
                rate, view = window_fps(mesh, seconds, args.size, args.cage)
                win.append(rate)
                print(f"{k + 1:>5} {web[-1]:>12.2f} {win[-1]:>11.2f}")
        finally:
            browser.close()
    finally:
        server.close()
    print(f"window: {view}")
    b, w = float(np.median(web)), float(np.median(win))
    print(f"web_fps: {mesh.name} {n} browser_fps={b:.2f} window_fps={w:.2f} ratio={b / w if w else float('inf'):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
