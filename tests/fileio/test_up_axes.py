"""The up axis chosen for a shape, remembered per shape (hybridedit.fileio.up_axes)."""

from __future__ import annotations

import pytest

from hybridedit.core.mesh import Mesh
from hybridedit.core.up_axis import guess_up_axis
from hybridedit.fileio.up_axes import remember_up_axis, remembered_up_axis, shape_key, up_axis_of

from shapes import bumpy_blob


def test_the_axis_chosen_is_remembered_per_shape(tmp_path, monkeypatch):
    monkeypatch.setenv("HYBRIDEDIT_CACHE_DIR", str(tmp_path))
    blob, other = bumpy_blob(3), bumpy_blob(2)
    key = shape_key(blob)
    assert remembered_up_axis(key) is None and up_axis_of(blob) == ("+Y", False)
    assert remember_up_axis(key, "-X")
    assert up_axis_of(blob) == ("-X", True) and up_axis_of(other) == (guess_up_axis(other), False)
    moved = Mesh(blob.vertices + 1e-9, blob.faces)  # another shape, however close
    assert shape_key(moved) != key
    (tmp_path / "up-axes.json").write_text("{not json")  # a damaged file is no memory, not an error
    assert remembered_up_axis(key) is None
    with pytest.raises(ValueError, match="up axis"):
        remember_up_axis(key, "up")

