"""The anti-aliasing rule shared by the window and the browser editor (viewer/render/gl_renderer.py)."""

from __future__ import annotations

import pyvista as pv

from hybridedit.viewer.render.gl_renderer import SAMPLES, choose_antialiasing, is_software


def test_software_opengl_is_told_from_a_gpu():
    assert is_software("llvmpipe (LLVM 15.0.6, 256 bits)") and is_software("Mesa softpipe")
    assert not is_software("NVIDIA GeForce RTX 4070/PCIe/SSE2") and not is_software("AMD Radeon Pro 5500M")


def test_an_off_screen_window_gets_multisampling_only_on_a_gpu():
    pl = pv.Plotter(off_screen=True, window_size=[64, 64])
    try:
        pl.add_mesh(pv.Sphere())
        pl.ren_win.Render()
        name, on = choose_antialiasing(pl.ren_win)
        assert name  # the renderer says what it is
        assert on == (not is_software(name))
        assert pl.ren_win.GetMultiSamples() == (SAMPLES if on else 0)
    finally:
        pl.close()
