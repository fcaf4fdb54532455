"""The pointer over the view in Pose mode, sent to the server so that the limb under it is shown with its
joint before the press (as the window's Pose tool shows it). The remote view sends the server mouse
moves only while a button is down; this listener sends the others, in Pose mode only, at most ten a
second, as ``[x, y]`` in the view's display pixels (origin bottom-left, device pixels, as VTK's events).
"""

from __future__ import annotations

from .brush_ring import VIEW_BOX_ID

HOVER_MILLISECONDS = 100
"""At most one hover a tenth of a second: a limb is shown at the pace of the images, not of the mouse."""

HOVER_SCRIPT = r"""
(function () {
  if (window.__hybrideditHover) return;
  window.__hybrideditHover = true;
  let last = 0, timer = null, pending = null;
  function send() {
    timer = null;
    if (!pending) return;
    last = Date.now();
    window.trame.trigger('hover', pending);
    pending = null;
  }
  document.addEventListener('mousemove', function (e) {
    const st = window.trame && window.trame.state;
    const box = document.getElementById('%(box)s');
    const canvas = box && box.querySelector('canvas');
    if (!st || !canvas || e.buttons !== 0 || st.get('mode') !== 'pose') return;
    const r = canvas.getBoundingClientRect();
    if (e.clientX < r.left || e.clientX > r.right || e.clientY < r.top || e.clientY > r.bottom) return;
    const dpr = window.devicePixelRatio || 1;
    pending = [(e.clientX - r.left) * dpr, (r.bottom - e.clientY) * dpr];
    const wait = %(ms)d - (Date.now() - last);
    if (wait <= 0) send();
    else if (!timer) timer = setTimeout(send, wait);
  }, true);
})();
""" % {"box": VIEW_BOX_ID, "ms": HOVER_MILLISECONDS}
"""The page's listener."""

__all__ = ["HOVER_SCRIPT"]
