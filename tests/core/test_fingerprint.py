"""The one shape fingerprint (hybridedit.core.fingerprint) and the keys made of it: each is kept on
disk (up-axes.json, binding cache file names, edit files, .blend files), so each digest is pinned to
the value it had before the keys shared one function."""

from __future__ import annotations

import numpy as np

from hybridedit.binding.cache import cache_key
from hybridedit.core.fingerprint import shape_bytes, shape_digest
from hybridedit.core.mesh import Mesh
from hybridedit.fileio.editfile import mesh_fingerprint
from hybridedit.fileio.up_axes import shape_key

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.5]])
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def test_the_persisted_keys_keep_their_digests():
    m = Mesh(V, F)
    assert shape_key(m) == "4c96d483bccac782080cec479ab33a462cde734b"
    assert mesh_fingerprint(m)["topology"] == "1c3efe47cee8dd9f"
    # (the binding cache's keys change, by design, with its FORMAT: these are binding-11's)
    assert cache_key(m, 0.05, 0.03) == "40116bfac84cc1fb3fd98158e5b70d75977eef9c7f349b14d93a6a7cd92820de"
    assert cache_key(m, 100, 0.03) == "04511da640e7bd6279d4cedbe57f3a40705a10d1da8ec8107af5e7e1836eaab3"
    # the Blender extension's (session.fingerprint): float32 positions, flat as Blender holds them
    blender = shape_digest(V.astype(np.float32).ravel(), F, "<f4")
    assert blender == "fde066a500104a4898b352c4e4c534f94e5d1d0ddd972d25ce1f578e1a40ab20"
    assert shape_digest(np.zeros(0, np.float32), F, "<f4") == \
        "ced77a56682cf6d68963ab0f9c032f90b2a3a35cbf5db08c7f15ae5503a5c1fe"  # its triangles_digest


def test_a_shape_is_one_shape_whatever_its_integer_and_memory_layout():
    count, v, f = shape_bytes(np.asfortranarray(V), F.astype(np.int32))
    assert np.frombuffer(count, np.int64).tolist() == [4] and v.flags.c_contiguous and f.dtype == np.dtype("<i8")
    assert shape_digest(np.asfortranarray(V), F.astype(np.int32)) == shape_digest(V, F)
    assert shape_digest(V, F[::-1]) != shape_digest(V, F) != shape_digest(V * (1 + 1e-15), F)
