"""The pose the next edit starts from (its base), and the shape propagated from it.

Successive edits compose: when a selection is set, the current pose becomes the
base of its drags. Their ARAP energy is measured against this pose, as sculpting
tools and CGAL's ``overwrite_initial_geometry`` do: the cage's edge vectors are
those of the base's cage and the region step's those of its shape, so that an
identity drag leaves every vertex where it is. The shape follows the cage as
M @ cage plus the base's residual (what the cage misses of the base pose),
turned with the cage. The rest pose is the first base.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .propagate import propagate
from .residual import propagate_with_residual

__all__ = ["BasePose", "propagated_residual", "propagate_from", "rest_base", "current_base", "fit_cage"]


@dataclass(frozen=True)
class BasePose:
    """The pose an edit starts from (its arrays are never modified in place).

    cage : (c, 3) float64 cage positions.
    shape : (n, 3) float64 shape positions.
    residual : (n, 3) float64 shape - M @ cage: what the cage misses of this pose,
        turned with it (zeros at rest for the linear propagation).
    at_rest : this is the rest pose (:meth:`hybridedit.HybridEditor.reset` goes back to it).
    """

    cage: np.ndarray
    shape: np.ndarray
    residual: np.ndarray
    at_rest: bool


def propagated_residual(base: BasePose, blend: tuple[np.ndarray, np.ndarray], *, propagation: str):
    """What the shape adds to M y' from ``base``: ``(d, idx, w)`` (d (n, 3) the base's
    residual, turned by the (n, k) rotation blend ``blend = (idx, w)``, or as it is
    for the linear propagation), or None for the paper's plain x' = M y' (the linear
    propagation from the rest pose)."""
    if propagation == "linear" and base.at_rest:
        return None
    return (base.residual, *blend)


def propagate_from(base: BasePose, *, binding: sp.csr_matrix, cage: np.ndarray, rotations: np.ndarray,
                   blend: tuple[np.ndarray, np.ndarray], propagation: str, out: np.ndarray) -> np.ndarray:
    """Every shape vertex, (n, 3) into ``out``, from (c, 3) ``cage`` positions and (c, 3, 3)
    ``rotations`` (the identity for the linear propagation), measured from ``base``."""
    residual = propagated_residual(base, blend, propagation=propagation)
    if residual is None:
        return propagate(binding, cage, out)
    return propagate_with_residual(binding, cage, rotations, *residual, out)


def rest_base(*, binding: sp.csr_matrix, cage: np.ndarray, residual: np.ndarray,
              blend: tuple[np.ndarray, np.ndarray], propagation: str, shape: np.ndarray) -> BasePose:
    """The rest pose as a base: the (c, 3) rest ``cage`` and the rest shape as the propagation
    gives it: the (n, 3) ``shape`` itself with the residual propagation (M @ cage plus the
    residual, which it equals to rounding: taken as it is, the rest pose is exact, and an
    11M-vertex shape opens without propagating every row), M @ cage with the linear one,
    whose residual is then zero.

    Parameters
    ----------
    residual : (n, 3) float64 rest shape - M @ cage (:func:`hybridedit.deform.residual.residual_setup`).
    shape : (n, 3) float64 the rest shape (referenced, never written).
    """
    if propagation == "residual":
        return BasePose(cage, shape, residual, at_rest=True)
    d = np.zeros_like(residual)
    out = np.empty((binding.shape[0], 3))
    propagate_from(BasePose(cage, None, d, at_rest=True), binding=binding, cage=cage,
                   rotations=np.tile(np.eye(3), (cage.shape[0], 1, 1)), blend=blend, propagation=propagation, out=out)
    return BasePose(cage, out, d, at_rest=True)


def current_base(base: BasePose, *, moved: bool, cage: np.ndarray, shape: np.ndarray,
                 binding: sp.csr_matrix) -> BasePose:
    """The current pose ((c, 3) ``cage``, (n, 3) ``shape``, copied) as the base of the next
    edit; ``base`` itself when nothing ``moved`` since it was taken."""
    if not moved:
        return base
    cage = cage.copy()
    shape = shape.copy()
    return BasePose(cage, shape, shape - binding @ cage, at_rest=False)


def fit_cage(vertices: np.ndarray, *, rest_shape: np.ndarray, rest_cage: np.ndarray,
             nearest: np.ndarray) -> np.ndarray:
    """(c, 3) cage positions for a shape pose ``vertices`` (n, 3): every cage vertex moves
    as the shape vertex ``nearest`` to it at rest ((c,) int64) did from ``rest_shape``."""
    return rest_cage + (vertices[nearest] - rest_shape[nearest])
