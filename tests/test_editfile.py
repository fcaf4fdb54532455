import json

import numpy as np
import pytest

from hybridedit.editfile import Edit, EditFileError, load_edit, save_edit


def test_round_trip(tmp_path):
    e = Edit(handle=np.array([3, 4]), roi=np.array([1, 2, 3, 4, 5]), translate=np.array([0.0, 1.5, 0.0]),
             rotate={"axis": np.array([0.0, 0, 1]), "degrees": 30.0, "center": np.array([1.0, 2, 3])})
    p = tmp_path / "e.json"
    save_edit(p, e)
    back = load_edit(p)
    assert back.handle.tolist() == [3, 4] and back.roi.tolist() == [1, 2, 3, 4, 5] and back.fixed is None
    assert np.allclose(back.transform(), e.transform())
    assert json.loads(p.read_text())["space"] == "shape"


def test_default_rotation_center_is_used_when_missing(tmp_path):
    p = tmp_path / "e.json"
    p.write_text(json.dumps({"handle": [0], "fixed": [1], "rotate": {"axis": [0, 0, 1], "degrees": 90}}))
    T = load_edit(p).transform(default_center=np.array([1.0, 0, 0]))
    assert np.allclose(T[:3, 3] + T[:3, :3] @ [1.0, 0, 0], [1.0, 0, 0])


@pytest.mark.parametrize(
    "text, words",
    [
        ("{not json", "not valid JSON"),
        ("[1, 2]", "JSON object"),
        ('{"fixed": [1]}', "missing \"handle\""),
        ('{"handle": []}', "empty"),
        ('{"handle": [1], "fixed": [2], "roi": [3]}', "not both"),
        ('{"handle": [1.5]}', "integer"),
        ('{"handle": [-1]}', "negative"),
        ('{"handle": [1], "translate": [1, 2]}', "3 finite numbers"),
        ('{"handle": [1], "translate": [1, 2, NaN]}', "3 finite numbers"),
        ('{"handle": [1], "rotate": {"axis": [0, 0, 0], "degrees": 5}}', "must not be zero"),
        ('{"handle": [1], "rotate": {"degrees": 5}}', "rotate"),
        ('{"handle": [1], "space": "world"}', "space"),
        ('{"handle": [1], "hadnle": [2]}', "unknown keys"),
    ],
)
def test_bad_edit_files_name_the_file_and_the_problem(tmp_path, text, words):
    p = tmp_path / "bad.json"
    p.write_text(text)
    with pytest.raises(EditFileError) as err:
        load_edit(p)
    assert "bad.json" in str(err.value) and words in str(err.value)


def test_missing_file(tmp_path):
    with pytest.raises(EditFileError, match="no such edit file"):
        load_edit(tmp_path / "nope.json")


def test_version_2_round_trip_with_groups_symmetry_and_fingerprint(tmp_path, blob):
    from hybridedit.editfile import HandleEdit, mesh_fingerprint
    from hybridedit.transforms import rigid_transform

    T = rigid_transform(translate=(0.1, 0.2, 0.3), axis=(1, 1, 0), degrees=33, center=(1, 2, 3))
    h0 = HandleEdit.from_matrix([1, 2], T, center=np.array([0.5, 0.5, 0.5]))
    h1 = HandleEdit(np.array([7]), translate=np.array([0, 0, 1.0]))
    h2 = HandleEdit(np.array([9]), matrix=np.diag([2.0, 1, 1, 1]))
    e = Edit(handles=[h0, h1, h2], roi=np.arange(20), symmetry="y", mesh=mesh_fingerprint(blob))
    p = tmp_path / "e.json"
    save_edit(p, e)
    data = json.loads(p.read_text())
    assert data["format"] == "hybridedit-edit" and data["version"] == 2 and len(data["handles"]) == 3
    back = load_edit(p)
    assert [h.indices.tolist() for h in back.handles] == [[1, 2], [7], [9]]
    assert np.allclose(back.handles[0].transform(), T, atol=1e-12)
    assert np.allclose(back.handles[2].transform(), np.diag([2.0, 1, 1, 1]))
    assert back.symmetry == "y" and back.mesh == mesh_fingerprint(blob) and back.roi.tolist() == list(range(20))


def test_version_1_files_still_load(tmp_path):
    p = tmp_path / "old.json"
    p.write_text(json.dumps({"handle": [3], "fixed": [1], "translate": [0, 1, 0]}))
    e = load_edit(p)
    assert len(e.handles) == 1 and e.handle.tolist() == [3] and np.allclose(e.transform()[:3, 3], [0, 1, 0])


def test_a_byte_order_mark_is_text(tmp_path):
    p = tmp_path / "bom.json"
    p.write_bytes(b"\xef\xbb\xbf" + json.dumps({"handle": [0], "fixed": [1]}).encode())
    assert load_edit(p).handle.tolist() == [0]


@pytest.mark.parametrize(
    "text, words",
    [
        ('{"handle": [1180591620717411303424]}', "far beyond any mesh"),
        ("[" * 100000 + "]" * 100000, "nested too deeply"),
        ('{"handle": [' + "9" * 5000 + "]}", "not a usable JSON file"),
        ('{"handles": []}', "non-empty list"),
        ('{"handles": [{"indices": [1], "matrix": [[1, 0], [0, 1]]}]}', "4x4 affine"),
        ('{"handles": [{"indices": [1], "spin": 3}]}', 'unknown keys in "handles[0]"'),
        ('{"handles": [{"indices": [1]}], "version": 9}', "version 9"),
        ('{"handles": [{"indices": [1]}], "symmetry": "w"}', "symmetry"),
        ('{"handles": [{"indices": [1]}], "mesh": {"vertices": 3}}', '"mesh" must hold'),
    ],
)
def test_more_bad_edit_files(tmp_path, text, words):
    p = tmp_path / "bad.json"
    p.write_text(text)
    with pytest.raises(EditFileError) as err:
        load_edit(p)
    msg = str(err.value)
    assert msg.startswith(str(p)) and words in msg and "\n" not in msg


def test_not_utf8_and_folders(tmp_path):
    p = tmp_path / "latin.json"
    p.write_bytes(b'{"handle": [1], "x": "\xe9"}')
    with pytest.raises(EditFileError, match="not UTF-8"):
        load_edit(p)
    with pytest.raises(EditFileError, match="is a folder"):
        load_edit(tmp_path)
