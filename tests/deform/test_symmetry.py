import numpy as np
import pytest

from hybridedit.deform.selection import SelectionError
from hybridedit.deform.symmetry import Mirror, reflection
from hybridedit.core.transforms import rigid_transform


def test_reflection_is_an_involution_across_its_plane():
    S = reflection([1.0, 2.0, 3.0], [0.0, 0.0, 2.0])
    assert np.allclose(S @ S, np.eye(4))
    assert np.allclose(S @ [5.0, 6.0, 3.0, 1.0], [5.0, 6.0, 3.0, 1.0])  # points on the plane stay
    assert np.allclose(S @ [0.0, 0.0, 4.0, 1.0], [0.0, 0.0, 2.0, 1.0])


def test_map_and_refusal():
    rng = np.random.default_rng(1)
    half = rng.normal(size=(50, 3))
    half[:, 0] = np.abs(half[:, 0]) + 0.1
    v = np.vstack([half, half * [-1, 1, 1]])
    m = Mirror(v, "x")
    assert m.asymmetry < 1e-12 and np.array_equal(m.map, np.r_[np.arange(50, 100), np.arange(50)])
    bumped = v.copy()
    bumped[0, 1] += 0.5
    with pytest.raises(SelectionError, match="not symmetric across this plane: a mirrored vertex is"):
        Mirror(bumped, "x")
    with pytest.raises(SelectionError, match="symmetry must be"):
        Mirror(v, "w")


def test_mirrored_and_symmetric_transforms():
    v = np.array([[-1.0, 0, 0], [1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0]])
    m = Mirror(v, "x")
    T = rigid_transform(translate=(0.3, 0.2, -0.1), axis=(1, 2, 3), degrees=25, center=(1, 0, 0))
    Tm = m.mirrored(T)
    p = np.array([1.0, 0.5, 0.2, 1.0])
    assert np.allclose(m.S @ (T @ p), Tm @ (m.S @ p))  # the mirror image moves as the mirror of the motion
    Ts = m.symmetric_part(T)
    assert np.allclose(m.S @ Ts, Ts @ m.S)  # commutes with the mirror
    assert np.allclose(Ts[:3, :3] @ Ts[:3, :3].T, np.eye(3))
