import numpy as np

from hybridedit.constraints import seam_band


def test_band_weights_fade_from_the_seam():
    x = np.linspace(0.0, 3.0, 31)
    p = np.stack([x, np.zeros_like(x), np.zeros_like(x)], 1)
    seam = np.array([0, 30])
    roles = np.array([-1, 1])
    free = np.arange(1, 30)
    band, nearest, w = seam_band(p, seam, roles, free, 1.0)
    assert band.tolist() == [*range(1, 10), *range(21, 30)]  # within 1.0 of either end (exclusive)
    assert nearest.shape == w.shape == (18, 2)
    left = w[:9, 0]
    assert np.all(np.diff(left) < 0) and left[0] < 1 and left[-1] > 0  # fades with distance
    assert np.all(w[:9, 1] == 0) and np.all(w[9:, 0] == 0)  # the other seam is out of reach
    assert np.all(seam[nearest[9:, 1]] == 30)


def test_empty_seam():
    band, nearest, w = seam_band(np.zeros((3, 3)), np.zeros(0, dtype=np.int64), np.zeros(0), np.arange(3), 1.0)
    assert band.size == 0 and w.shape[0] == 0
