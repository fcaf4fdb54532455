"""Headless Chromium through selenium, for the browser editor's tests (``hybridedit web``, ``he.widget``).

Without Chromium, chromedriver or the web and test extras the tests are skipped, unless
HYBRIDEDIT_REQUIRE_VALIDATORS is set (.ci/run), where that fails.
"""

from __future__ import annotations

import os
import shutil
import socket
import time
from pathlib import Path

import numpy as np
import pytest

CHROMIUM = next((p for p in ("/usr/bin/chromium", "/usr/bin/chromium-browser") if os.path.exists(p)), None)
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
REQUIRED = bool(os.environ.get("HYBRIDEDIT_REQUIRE_VALIDATORS"))


def need(ok: bool, reason: str) -> None:
    """Skip (or, where the validators are required, fail) unless ``ok``."""
    if not ok:
        if REQUIRED:
            pytest.fail(f"{reason} (HYBRIDEDIT_REQUIRE_VALIDATORS is set)")
        pytest.skip(reason)


def need_browser() -> None:
    """Chromium, chromedriver, trame and selenium are all here."""
    need(CHROMIUM is not None and os.path.exists(CHROMEDRIVER), "Chromium or chromedriver is not installed")
    for module in ("trame", "trame_vtk", "trame_vuetify", "selenium"):
        try:
            __import__(module)
        except ImportError:
            need(False, f"{module} is not installed (the web and test extras)")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait(pred, timeout: float = 20.0, step: float = 0.2):
    """``pred()`` once it is true (an array counts as true), else its value at the timeout."""
    end = time.time() + timeout
    while time.time() < end:
        got = pred()
        if isinstance(got, np.ndarray) or got:
            return got
        time.sleep(step)
    return pred()


def new_driver(size: tuple[int, int], downloads: Path | None = None):
    """A headless Chromium window of ``size`` pixels (device scale 1), saving downloads to ``downloads``."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", f"--window-size={size[0]},{size[1]}",
              "--force-device-scale-factor=1"):
        opts.add_argument(a)
    d = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    if downloads is not None:
        d.execute_cdp_cmd("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(downloads)})
    return d


def drawn_fraction(d, element, shot: Path) -> float:
    """The fraction of ``element``'s box on the page's screenshot that is not its background (its median)."""
    from PIL import Image

    r = d.execute_script("return arguments[0].getBoundingClientRect()", element)
    d.save_screenshot(str(shot))
    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    view = img[int(r["top"]):int(r["bottom"]), int(r["left"]):int(r["right"])]
    if view.size == 0:
        return 0.0
    background = np.median(view.reshape(-1, 3), axis=0)
    return float((np.abs(view - background).sum(axis=2) > 40).mean())
