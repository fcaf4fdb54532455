"""The keyboard shortcuts of the browser editor: the page's listener, and what each key does.

The listener runs in the capture phase (before vtk.js or Vuetify can stop the event),
skips typing in text fields, and sends ``[key, ctrl, shift]`` to the server's ``hotkey``
trigger; :func:`action_of` names the editor action it stands for.
"""

from __future__ import annotations

PLAIN_KEYS = {"s": "select", "r": "target_roi", "h": "target_handle", "d": "drag", "c": "camera"}
"""Keys without Ctrl: the modes (Select, Drag, Camera) and the selection's target (ROI, Handle)."""

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
    """The editor action of a key press: Ctrl+Z undo, Ctrl+Shift+Z and Ctrl+Y redo, the plain keys of
    :data:`PLAIN_KEYS`; None for any other key."""
    key = key.lower()
    if ctrl:
        return {"z": "redo" if shift else "undo", "y": "redo"}.get(key)
    return PLAIN_KEYS.get(key)
