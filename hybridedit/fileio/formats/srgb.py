"""Vertex colours between display (sRGB-encoded) values and linear ones: the one rule every format uses.

A :class:`~hybridedit.fileio.document.Document` holds display values, as PLY, OBJ and OFF store
them (a byte over 255 is what a screen shows). glTF 2.0's ``COLOR_0`` holds linear values, and so
does USD's ``primvars:displayColor`` (its fallback colour space, with none authored, is linear
Rec.709: sRGB's primaries without its transfer function): their readers and writers convert here,
with the sRGB transfer function of IEC 61966-2-1 (the one the glTF specification names). Alpha is
coverage, not light: it is never converted.
"""

from __future__ import annotations

import numpy as np

__all__ = ["linear_to_srgb", "srgb_to_linear"]


def _channels(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A float64 copy of ``values`` (..., 3 or 4) and its colour channels, clipped to [0, 1]."""
    out = np.array(values, dtype=np.float64)
    if out.ndim == 0 or out.shape[-1] not in (3, 4):
        raise ValueError(f"colours must be (..., 3) RGB or (..., 4) RGBA, not {out.shape}")
    return out, np.clip(out[..., :3], 0.0, 1.0)


def srgb_to_linear(values: np.ndarray) -> np.ndarray:
    """Linear values of display (sRGB-encoded) colours, as glTF's ``COLOR_0`` holds them.

    Parameters
    ----------
    values : (..., 3) or (..., 4) array_like of float
        RGB or RGBA in [0, 1] (colour channels outside are clipped to it).

    Returns
    -------
    (..., 3) or (..., 4) float64 ndarray
        A new array: R, G and B decoded, ``c / 12.92`` up to 0.04045 and
        ``((c + 0.055) / 1.055) ** 2.4`` above; a fourth column (alpha) as it was.

    Examples
    --------
    >>> srgb_to_linear([[0.5, 1.0, 0.0, 0.25]]).round(6)
    array([[0.214041, 1.      , 0.      , 0.25    ]])
    """
    out, c = _channels(values)
    out[..., :3] = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return out


def linear_to_srgb(values: np.ndarray) -> np.ndarray:
    """Display (sRGB-encoded) values of linear colours: the inverse of :func:`srgb_to_linear`.

    Parameters
    ----------
    values : (..., 3) or (..., 4) array_like of float
        RGB or RGBA in [0, 1] (colour channels outside are clipped to it).

    Returns
    -------
    (..., 3) or (..., 4) float64 ndarray
        A new array: R, G and B encoded, ``12.92 * c`` up to 0.0031308 and
        ``1.055 * c ** (1 / 2.4) - 0.055`` above; a fourth column (alpha) as it was.

    Examples
    --------
    >>> linear_to_srgb([[0.214041, 1.0, 0.0, 0.25]]).round(6)
    array([[0.5 , 1.  , 0.  , 0.25]])
    """
    out, c = _channels(values)
    out[..., :3] = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    return out
