import numpy as np
import pytest

from hybridedit.core.transforms import apply_transform, check_transform, rigid_transform


def test_rotation_about_center_keeps_center_and_distances():
    c = np.array([1.0, 2.0, 3.0])
    T = rigid_transform(axis=(0, 0, 1), degrees=90, center=c)
    assert np.allclose(apply_transform(T, c), c)
    p = c + [1.0, 0, 0]
    assert np.allclose(apply_transform(T, p), c + [0, 1.0, 0])
    pts = np.random.default_rng(0).normal(size=(20, 3))
    q = apply_transform(T, pts)
    assert np.allclose(np.linalg.norm(pts[1:] - pts[0], axis=1), np.linalg.norm(q[1:] - q[0], axis=1))


def test_translation_is_applied_after_rotation():
    T = rigid_transform(translate=(1, 0, 0), axis=(0, 1, 0), degrees=180, center=(0, 0, 0))
    assert np.allclose(apply_transform(T, [[1.0, 0, 0]]), [[0.0, 0, 0]])


@pytest.mark.parametrize(
    "kwargs",
    [dict(degrees=10), dict(axis=(0, 0, 0), degrees=10), dict(axis=(1, 0, 0), degrees=float("nan")),
     dict(translate=(np.inf, 0, 0))],
)
def test_bad_transforms_are_refused(kwargs):
    with pytest.raises(ValueError):
        rigid_transform(**kwargs)


def test_check_transform():
    with pytest.raises(ValueError, match="4x4"):
        check_transform(np.eye(3))
    bad = np.eye(4)
    bad[3, 0] = 1
    with pytest.raises(ValueError, match="last row"):
        check_transform(bad)


@pytest.mark.parametrize("deg", [0.0, 1e-3, 37.0, 179.999, 180.0])
def test_decompose_rigid_inverts_rigid_transform(deg):
    from hybridedit.core.transforms import decompose_rigid

    axis, center = np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -1.0])
    T = rigid_transform(translate=(1, 2, 3), axis=axis, degrees=deg, center=center)
    translate, rotate = decompose_rigid(T, center)
    if deg == 0:
        assert rotate is None and np.allclose(translate, [1, 2, 3])
        return
    again = rigid_transform(translate=translate, axis=rotate["axis"], degrees=rotate["degrees"],
                            center=rotate["center"])
    assert np.allclose(again, T, atol=1e-12)
    assert np.isclose(rotate["degrees"], deg)
