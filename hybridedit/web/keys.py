"""The keyboard shortcuts of the browser editor: the page's listener, and what each key does.

The actions are named as the window's (:mod:`hybridedit.viewer.window.actions`), and each key is the
window's shortcut for it (a test holds them together).

The listener runs in the capture phase (before vtk.js or Vuetify can stop the event),
skips typing in text fields, and sends ``[key, ctrl, shift]`` to the server's ``hotkey``
trigger; :func:`action_of` names the editor action it stands for.
"""

from __future__ import annotations

PLAIN_KEYS = {"s": "mode_select", "r": "target_roi", "h": "target_handle", "d": "mode_drag", "c": "mode_camera",
              "p": "mode_pose",
              "x": "tool_rect", "b": "tool_brush", "[": "brush_smaller", "]": "brush_bigger",
              "t": "stretch", "f": "reset_camera"}
"""Keys without Ctrl, as the window has them: the modes (Select, Drag, Pose, Camera), the selection's target
(ROI, Handle), its tool (Rectangle, Brush) and the brush's size, the stretch map, Frame Shape."""

SHIFT_KEYS = {"x": "mirror_x", "f": "free_around_handle"}
"""Keys with Shift: Mirror X, Free Around Handle (the window's Shift+X and Shift+F)."""

KEY_SCRIPT = r"""
(function () {
  if (window.__hybrideditKeys) return;
  window.__hybrideditKeys = true;
  window.addEventListener('keydown', function (e) {
    const t = e.target;
    if (t && (t.tagName === 'TEXTAREA' || t.isContentEditable ||
              (t.tagName === 'INPUT' && !['checkbox', 'radio', 'button', 'range'].includes(t.type)))) return;
    const k = (e.key || '').toLowerCase();
    const ctrl = e.ctrlKey || e.metaKey;
    const plain = %s;
    if (ctrl ? !['z', 'y'].includes(k) : !plain.includes(k)) return;  // Ctrl+S, Ctrl+R ... stay the browser's
    e.preventDefault();
    window.trame.trigger('hotkey', [k, ctrl, e.shiftKey]);
  }, true);
})();
""" % repr(sorted(PLAIN_KEYS))


def action_of(key: str, ctrl: bool, shift: bool) -> str | None:
    """The editor action of a key press: Ctrl+Z undo, Ctrl+Shift+Z and Ctrl+Y redo, the keys of
    :data:`SHIFT_KEYS` with Shift, those of :data:`PLAIN_KEYS`; None for any other key."""
    key = key.lower()
    if ctrl:
        return {"z": "redo" if shift else "undo", "y": "redo"}.get(key)
    if shift and key in SHIFT_KEYS:
        return SHIFT_KEYS[key]
    return PLAIN_KEYS.get(key)
