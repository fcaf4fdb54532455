"""The keyboard shortcuts of the browser editor: the page's listener, and what each key does.

The actions are named as the window's (:mod:`hybridedit.viewer.window.actions`), and each key is the
window's shortcut for it (a test holds them together).

The listener runs in the capture phase (before vtk.js or Vuetify can stop the event),
skips typing in text fields, and sends ``[key, ctrl, shift, alt]`` to the server's ``hotkey``
trigger; :func:`action_of` names the editor action it stands for.
"""

from __future__ import annotations

PLAIN_KEYS = {"s": "mode_select", "r": "target_roi", "h": "target_handle", "d": "mode_drag", "c": "mode_camera",
              "p": "mode_pose",
              "x": "tool_rect", "b": "tool_brush", "[": "brush_smaller", "]": "brush_bigger",
              "t": "stretch", "f": "reset_camera", "g": "next_group"}
"""Keys without Ctrl, as the window has them: the modes (Select, Drag, Pose, Camera), the selection's target
(ROI, Handle), its tool (Rectangle, Brush) and the brush's size, the stretch map, Frame Shape, Next Handle
Group."""

SHIFT_KEYS = {"x": "mirror_x", "f": "free_around_handle"}
"""Keys with Shift: Mirror X, Free Around Handle (the window's Shift+X and Shift+F)."""

CTRL_KEYS = {"z": "undo", "y": "redo", "g": "new_group"}
"""Keys with Ctrl: Undo (with Shift: Redo), Redo (the browser's Ctrl+Y too), New Handle Group."""

ALT_KEYS = {"z": "select_through"}
"""Keys with Alt: Select Through (the window's Alt+Z)."""

KEY_SCRIPT = r"""
(function () {
  if (window.__hybrideditKeys) return;
  window.__hybrideditKeys = true;
  window.addEventListener('keydown', function (e) {
    const t = e.target;
    if (t && (t.tagName === 'TEXTAREA' || t.isContentEditable ||
              (t.tagName === 'INPUT' && !['checkbox', 'radio', 'button', 'range'].includes(t.type)))) return;
    const ctrl = e.ctrlKey || e.metaKey;
    // (with Alt a letter's key is another character on some layouts: the key's place names it)
    const k = (e.altKey && /^Key[A-Z]$/.test(e.code || '')) ? e.code.slice(3).toLowerCase()
                                                           : (e.key || '').toLowerCase();
    const keys = ctrl ? %s : e.altKey ? %s : %s;
    if (!keys.includes(k)) return;  // Ctrl+S, Ctrl+R ... stay the browser's
    e.preventDefault();
    window.trame.trigger('hotkey', [k, ctrl, e.shiftKey, e.altKey]);
  }, true);
})();
""" % (repr(sorted(CTRL_KEYS)), repr(sorted(ALT_KEYS)), repr(sorted(PLAIN_KEYS)))


def action_of(key: str, ctrl: bool, shift: bool, alt: bool = False) -> str | None:
    """The editor action of a key press: those of :data:`CTRL_KEYS` with Ctrl (Ctrl+Shift+Z redo), of
    :data:`ALT_KEYS` with Alt, of :data:`SHIFT_KEYS` with Shift, of :data:`PLAIN_KEYS`; None for any other
    key."""
    key = key.lower()
    if ctrl:
        return "redo" if (key, shift) == ("z", True) else CTRL_KEYS.get(key)
    if alt:
        return ALT_KEYS.get(key)
    if shift and key in SHIFT_KEYS:
        return SHIFT_KEYS[key]
    return PLAIN_KEYS.get(key)
