"""The engine's side of a Bind, with no Blender in it: a :class:`~.session.Session` built from what
Bind read on the main thread (the float32 rest, the triangles, the groups' rows).

Bind's worker thread runs it (:class:`.bind.BindJob`), and so does the background compile
(:mod:`.precompile`, a process of its own without bpy) on small shapes: the same calls with the
same array types, so that the kernels it compiles are the ones Bind then loads from the cache.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from . import session as S

Progress = Callable[[str, float], None]


def build_session(*, uid: str, object_name: str, rest32: np.ndarray, basis32: np.ndarray, tris: np.ndarray,
                  counts: tuple[int, int, int], digest: str, groups: list[str], handle_rows: list[np.ndarray],
                  roi: np.ndarray | None, roi_group: str, stretch: np.ndarray | None, cage_size: float,
                  iterations: int, cache_dir: str, progress: Progress) -> S.Session:
    """Cage and binding (``build_rig``, cached in ``cache_dir`` by the mesh's content), the editor,
    the selection and one frame at rest (its kernels compiled now, not at the first move).

    Parameters
    ----------
    rest32, basis32 : (n*3,) float32
        The rest (the shape-key mix without the pose key) and the reference key's positions, local.
    tris : (m, 3) int64
        Blender's triangulation of the polygons.
    handle_rows : list of (k,) int64
        Each handle group's vertices; ``roi`` the ROI group's (None: nothing fixed).
    stretch : (3, 3) float64 or None
        The object's stretch (the engine solves the world shape ``stretch @ rest``).
    progress : callable (stage, fraction)
        Called as the work goes on; may raise :class:`~.session.Cancelled` to stop it.
    """
    import hybridedit as he

    V = rest32.reshape(-1, 3).astype(np.float64)
    if stretch is not None:  # the world shape (as Apply Scale makes it)
        V = V @ stretch.T
    with S.ENGINE:
        mesh = he.Mesh(V, tris, name=object_name)
        rig = he.build_rig(mesh, cage_size=cage_size, cache=cache_dir, progress=progress)
        progress("preparing the editor", 0.0)
        ed = he.HybridEditor(rig, iterations=iterations)
        base = S.Base(digest, rest32.copy(), basis32.copy())
        s = S.Session(uid, object_name, ed, base, S.triangles_digest(tris), counts, groups=groups,
                      roi_group=roi_group, roi=roi, handle_rows=handle_rows, stretch=stretch,
                      cage_size=cage_size, cache_hit=rig.cache_hit, notes=tuple(rig.notes))
        progress("factoring the selection", 0.0)
        s.select()
        # compile the frame kernels now (first use), not at the first move of an Empty
        progress("compiling the frame", 0.0)
        ed.drag(transforms={g: np.eye(4) for g in range(len(groups))})
        ed.restore_state(s.base.state)
    return s
