"""Which OpenGL draws a render window, and the anti-aliasing it gets: one rule for the window
and the browser editor.

Multisampling costs software OpenGL (Mesa's llvmpipe, what a machine with no GPU has) about
twice the frame (100K triangles: 280 against 150 ms a frame in the browser editor's off-screen
window), for edges a drag does not need, so it is on only for a GPU.
"""

from __future__ import annotations

SOFTWARE_GL = ("llvmpipe", "softpipe", "swrast", "software", "lavapipe")
"""Words in the OpenGL renderer string of a software (CPU) implementation."""

SAMPLES = 4
"""Multisamples where anti-aliasing is on."""


def renderer_name(ren_win) -> str:
    """The OpenGL renderer string of a render window that has rendered once ("" when it does not say)."""
    for line in ren_win.ReportCapabilities().splitlines():
        if "renderer string" in line:
            return line.split(":", 1)[1].strip()
    return ""


def is_software(name: str) -> bool:
    """The renderer string names a software OpenGL."""
    return any(k in name.lower() for k in SOFTWARE_GL)


def choose_antialiasing(ren_win) -> tuple[str, bool]:
    """Multisampling on for a GPU, off for software OpenGL, on a window that has rendered once;
    returns (the renderer string, on)."""
    name = renderer_name(ren_win)
    on = not is_software(name)
    ren_win.SetMultiSamples(SAMPLES if on else 0)
    return name, on
