"""The sRGB transfer function the formats share (hybridedit.fileio.formats.srgb): its values, its inverse,
every byte colour surviving a float32 linear file, alpha untouched."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.fileio.formats.srgb import linear_to_srgb, srgb_to_linear


def grey(values: np.ndarray) -> np.ndarray:
    """(k, 3): each value as an RGB grey."""
    return np.repeat(np.asarray(values, dtype=np.float64)[:, None], 3, axis=1)


def test_known_values_of_the_transfer_function():
    # 0.5 display is 21.4% of the light; 0.04 is on the linear toe (over 12.92)
    lin = srgb_to_linear(grey([0.0, 0.04, 0.5, 1.0]))[:, 0]
    np.testing.assert_allclose(lin, [0.0, 0.04 / 12.92, 0.21404114, 1.0], rtol=1e-7, atol=0)
    enc = linear_to_srgb(grey([0.0, 0.002, 0.21404114, 1.0]))[:, 0]
    np.testing.assert_allclose(enc, [0.0, 0.002 * 12.92, 0.5, 1.0], rtol=1e-7, atol=0)


def test_the_two_pieces_meet_at_the_thresholds():
    # (IEC 61966-2-1's rounded constants leave steps of 2e-9 and 3e-8 there, far below a byte's 4e-3)
    below, above = np.nextafter(0.04045, 0.0), np.nextafter(0.04045, 1.0)
    lo, hi = srgb_to_linear(grey([below, above]))[:, 0]
    assert abs(hi - lo) < 1e-7
    below, above = np.nextafter(0.0031308, 0.0), np.nextafter(0.0031308, 1.0)
    lo, hi = linear_to_srgb(grey([below, above]))[:, 0]
    assert abs(hi - lo) < 1e-7


def test_each_is_the_others_inverse_and_both_increase():
    x = grey(np.linspace(0.0, 1.0, 10001))
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(x)), x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(srgb_to_linear(linear_to_srgb(x)), x, rtol=0, atol=1e-12)
    assert np.all(np.diff(srgb_to_linear(x)[:, 0]) > 0) and np.all(np.diff(linear_to_srgb(x)[:, 0]) > 0)
    assert np.all(srgb_to_linear(x)[1:-1, 0] < x[1:-1, 0])  # linear values are darker numbers


def test_every_byte_colour_comes_back_from_float32_linear_values():
    """What a PLY -> GLB -> PLY conversion does to a channel: bytes / 255, linear float32, back, rounded."""
    b = np.arange(256)
    stored = srgb_to_linear(grey(b / 255)).astype(np.float32)
    back = np.rint(linear_to_srgb(stored) * 255)
    assert np.array_equal(back, grey(b))


def test_alpha_is_kept_bit_for_bit_and_shapes_and_inputs_too():
    rng = np.random.default_rng(7)
    rgba = rng.random((4, 5, 4))
    before = rgba.copy()
    for convert in (srgb_to_linear, linear_to_srgb):
        out = convert(rgba)
        assert out.shape == rgba.shape and out.dtype == np.float64
        assert np.array_equal(out[..., 3], rgba[..., 3])
        assert not np.allclose(out[..., :3], rgba[..., :3])
        assert convert(rgba[..., :3]).shape == (4, 5, 3)
    assert np.array_equal(rgba, before)  # (new arrays, the input left alone)


def test_colour_channels_outside_zero_to_one_are_clipped():
    out = srgb_to_linear([[-0.5, 1.5, 0.5, 2.0]])
    assert out[0, 0] == 0.0 and out[0, 1] == 1.0 and out[0, 3] == 2.0 and np.isfinite(out).all()


@pytest.mark.parametrize("shape", [(), (5,), (5, 2), (5, 5)])
def test_anything_but_rgb_or_rgba_rows_is_refused(shape):
    with pytest.raises(ValueError, match="colours must be"):
        srgb_to_linear(np.zeros(shape))
