"""Rigid transforms as 4x4 homogeneous matrices (rotations through scipy's ``Rotation``)."""

from __future__ import annotations

import numpy as np


def rigid_transform(
    translate: np.ndarray | tuple | None = None,
    axis: np.ndarray | tuple | None = None,
    degrees: float = 0.0,
    center: np.ndarray | tuple | None = None,
) -> np.ndarray:
    """x -> R (x - center) + center + translate, as a (4, 4) float64 matrix.

    Parameters
    ----------
    translate : (3,) translation, default 0.
    axis : (3,) rotation axis (any length > 0); needed when ``degrees`` != 0.
    degrees : rotation angle about ``axis`` (right-hand rule).
    center : (3,) point the rotation is about, default the origin.
    """
    T = np.eye(4)
    if degrees:
        if axis is None:
            raise ValueError("a rotation needs an axis")
        a = np.asarray(axis, dtype=np.float64).reshape(3)
        n = np.linalg.norm(a)
        if not np.isfinite(n) or n == 0:
            raise ValueError(f"rotation axis must be a nonzero finite vector, got {list(a)}")
        if not np.isfinite(degrees):
            raise ValueError(f"rotation angle must be finite, got {degrees}")
        from scipy.spatial.transform import Rotation  # imported when used: the CLI starts fast

        R = Rotation.from_rotvec(a / n * np.radians(float(degrees))).as_matrix()
        c = np.zeros(3) if center is None else np.asarray(center, dtype=np.float64).reshape(3)
        T[:3, :3] = R
        T[:3, 3] = c - R @ c
    if translate is not None:
        t = np.asarray(translate, dtype=np.float64).reshape(3)
        T[:3, 3] += t
    if not np.all(np.isfinite(T)):
        raise ValueError("transform has non-finite entries")
    return T


def apply_transform(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a (4, 4) affine transform to (k, 3) float64 points."""
    T = np.asarray(T, dtype=np.float64)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return p @ T[:3, :3].T + T[:3, 3]


def check_transform(T: np.ndarray) -> np.ndarray:
    """Validate a transform: a finite (4, 4) affine matrix (last row 0 0 0 1)."""
    T = np.asarray(T, dtype=np.float64)
    if T.shape != (4, 4):
        raise ValueError(f"transform must be a 4x4 matrix, got shape {T.shape}")
    if not np.all(np.isfinite(T)):
        raise ValueError("transform has non-finite entries")
    if not np.allclose(T[3], [0, 0, 0, 1]):
        raise ValueError("transform's last row must be 0 0 0 1")
    return T


def decompose_rigid(T: np.ndarray, center: np.ndarray) -> tuple[np.ndarray, dict | None]:
    """Split a rigid transform into a rotation about ``center`` and a translation.

    ``x -> R (x - center) + center + translate`` equals ``T`` (as
    :func:`rigid_transform` builds it).

    Parameters
    ----------
    T : (4, 4) rigid transform (orthonormal rotation part, det +1).
    center : (3,) the point the rotation is about.

    Returns
    -------
    translate : (3,) float64
    rotate : None for no rotation, else {"axis": (3,) unit, "degrees": float in (0, 180],
        "center": (3,)}

    Raises
    ------
    ValueError
        When ``T`` is not a rigid transform.
    """
    T = np.asarray(T, dtype=np.float64)
    R = T[:3, :3]
    if not np.all(np.isfinite(T)) or not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise ValueError("the handle transform is not a rotation plus a translation")
    c = np.asarray(center, dtype=np.float64).reshape(3)
    translate = T[:3, 3] - (c - R @ c)
    from scipy.spatial.transform import Rotation

    rotvec = Rotation.from_matrix(R).as_rotvec()
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-12:
        return T[:3, 3].copy(), None
    return translate, {"axis": rotvec / angle, "degrees": float(np.degrees(angle)), "center": c}
