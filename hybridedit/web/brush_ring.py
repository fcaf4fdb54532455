"""The brush's outline in the browser: a ring that follows the mouse over the view in Select mode
with the Brush, sized by the server's brush radius and coloured as the target (the window draws the
same ring itself).

The ring is drawn by the page (a ``div`` moved by a mouse listener), not by the server: it must follow
the mouse at the browser's pace, not at the pace of the images.
"""

from __future__ import annotations

from ..viewer.render.palette import ROLE_COLORS

RING_ID, VIEW_BOX_ID = "brush_ring", "view_box"
"""The ids of the ring and of the element holding the view."""


def _hex(rgb) -> str:
    return "#" + "".join(f"{int(c):02x}" for c in rgb)


RING_SCRIPT = r"""
(function () {
  if (window.__hybrideditBrushRing) return;
  window.__hybrideditBrushRing = true;
  document.addEventListener('mousemove', function (e) {
    const box = document.getElementById('%(box)s'), ring = document.getElementById('%(ring)s');
    const st = window.trame && window.trame.state;
    if (!box || !ring || !st) return;
    const r = box.getBoundingClientRect();
    const inside = e.clientX >= r.left && e.clientX <= r.right && e.clientY >= r.top && e.clientY <= r.bottom;
    const on = inside && st.get('mode') === 'select' && st.get('tool') === 'brush';
    ring.style.display = on ? 'block' : 'none';
    if (!on) return;
    const radius = (st.get('brush_px') || 30) / (window.devicePixelRatio || 1);
    ring.style.width = ring.style.height = (2 * radius) + 'px';
    ring.style.left = (e.clientX - r.left - radius) + 'px';
    ring.style.top = (e.clientY - r.top - radius) + 'px';
    ring.style.borderColor = st.get('target') === 'handle' ? '%(handle)s' : '%(roi)s';
  }, true);
})();
""" % {"box": VIEW_BOX_ID, "ring": RING_ID, "roi": _hex(ROLE_COLORS[1]), "handle": _hex(ROLE_COLORS[2])}
"""The page's listener that places the ring (display pixels of the server over the device pixel ratio)."""

RING_STYLE = ("position: absolute; display: none; border: 2px solid; border-radius: 50%;"
              " pointer-events: none; box-sizing: border-box")
"""The ring's own style (it never takes the mouse from the view)."""

__all__ = ["RING_ID", "RING_SCRIPT", "RING_STYLE", "VIEW_BOX_ID"]
