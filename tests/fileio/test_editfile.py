import json

import numpy as np
import pytest

from hybridedit.fileio.editfile import Edit, EditFileError, load_edit, save_edit


def test_round_trip(tmp_path):
    e = Edit(handle=np.array([3, 4]), roi=np.array([1, 2, 3, 4, 5]), translate=np.array([0.0, 1.5, 0.0]),
             rotate={"axis": np.array([0.0, 0, 1]), "degrees": 30.0, "center": np.array([1.0, 2, 3])})
    p = tmp_path / "e.json"
    save_edit(p, e)
    back = load_edit(p)
    assert back.handle.tolist() == [3, 4] and back.roi.tolist() == [1, 2, 3, 4, 5] and back.fixed is None
    assert np.allclose(back.transform(), e.transform())
    assert json.loads(p.read_text())["steps"][0]["space"] == "shape"


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


def test_round_trip_with_groups_symmetry_and_fingerprint(tmp_path, blob):
    from hybridedit.fileio.editfile import HandleEdit, mesh_fingerprint
    from hybridedit.core.transforms import rigid_transform

    T = rigid_transform(translate=(0.1, 0.2, 0.3), axis=(1, 1, 0), degrees=33, center=(1, 2, 3))
    h0 = HandleEdit.from_matrix([1, 2], T, center=np.array([0.5, 0.5, 0.5]))
    h1 = HandleEdit(np.array([7]), translate=np.array([0, 0, 1.0]))
    h2 = HandleEdit(np.array([9]), matrix=np.diag([2.0, 1, 1, 1]))
    e = Edit(handles=[h0, h1, h2], roi=np.arange(20), symmetry="y", mesh=mesh_fingerprint(blob))
    p = tmp_path / "e.json"
    save_edit(p, e)
    data = json.loads(p.read_text())
    assert data["format"] == "hybridedit-edit" and data["version"] == 3 and len(data["steps"][0]["handles"]) == 3
    back = load_edit(p)
    assert [h.indices.tolist() for h in back.handles] == [[1, 2], [7], [9]]
    assert np.allclose(back.handles[0].transform(), T, atol=1e-12)
    assert np.allclose(back.handles[2].transform(), np.diag([2.0, 1, 1, 1]))
    assert back.symmetry == "y" and back.mesh == mesh_fingerprint(blob) and back.roi.tolist() == list(range(20))


def test_version_2_files_still_load(tmp_path, blob):
    from hybridedit.fileio.editfile import mesh_fingerprint

    p = tmp_path / "v2.json"
    p.write_text(json.dumps({"format": "hybridedit-edit", "version": 2, "mesh": mesh_fingerprint(blob),
                             "space": "shape", "roi": [1, 2, 3], "symmetry": "x",
                             "handles": [{"indices": [3], "translate": [0, 1, 0]}, {"indices": [5]}]}))
    e = load_edit(p)
    assert len(e.steps) == 1 and e.iterations is None and e.polish is None and not e.continues
    assert [h.indices.tolist() for h in e.handles] == [[3], [5]] and e.roi.tolist() == [1, 2, 3]
    assert e.symmetry == "x" and e.mesh == mesh_fingerprint(blob)


def test_version_3_steps_round_trip(tmp_path, blob):
    """A chain: a selection settled and polished, the same selection dragged on (it continues), then
    another selection on another cage, with a plane of symmetry."""
    from hybridedit.fileio.editfile import HandleEdit, mesh_fingerprint
    from hybridedit.core.transforms import rigid_transform

    T1 = rigid_transform(translate=(0.1, 0.0, 0.0), axis=(0, 0, 1), degrees=20, center=(1, 0, 0))
    first = Edit(handles=[HandleEdit.from_matrix([4, 5], T1, center=np.array([1.0, 0, 0]))], roi=np.arange(30),
                 iterations=60, polish=37, cage={"size": 0.05, "vertices": 120})
    second = Edit(handles=[HandleEdit(first.handles[0].indices, translate=np.array([0, 0.2, 0]))], roi=first.roi,
                  continues=True, iterations=60, cage={"size": 0.05, "vertices": 120})
    plane = (np.array([0.0, 0, 0]), np.array([1.0, 0, 0]))
    last = Edit(handles=[HandleEdit(np.array([8]))], fixed=np.array([1, 2]), symmetry=plane, iterations=0,
                cage={"size": 300, "vertices": 300}, before=[first, second], mesh=mesh_fingerprint(blob))
    p = tmp_path / "chain.json"
    save_edit(p, last)
    data = json.loads(p.read_text())
    assert data["version"] == 3 and len(data["steps"]) == 3
    assert "indices" not in data["steps"][1]["handles"][0] and "roi" not in data["steps"][1]
    back = load_edit(p)
    assert len(back.steps) == 3 and back.mesh == mesh_fingerprint(blob)
    b1, b2, b3 = back.steps
    assert (b1.iterations, b1.polish, b1.cage, b1.continues) == (60, 37, {"size": 0.05, "vertices": 120}, False)
    assert np.allclose(b1.handles[0].transform(), T1, atol=1e-12)
    assert b2.continues and b2.handles[0].indices.tolist() == [4, 5] and b2.roi.tolist() == list(range(30))
    assert b2.polish is None and np.allclose(b2.handles[0].translate, [0, 0.2, 0])
    assert b3.fixed.tolist() == [1, 2] and b3.iterations == 0 and b3.cage == {"size": 300, "vertices": 300}
    assert np.allclose(b3.symmetry[0], 0) and np.allclose(b3.symmetry[1], [1, 0, 0])


@pytest.mark.parametrize(
    "steps, words",
    [
        ([], "non-empty list of steps"),
        ([{"continues": True, "handles": [{}]}], "cannot continue"),
        ([{"handles": [{"indices": [1]}]}, {"continues": True, "handles": [{}, {}]}], "has 2 groups"),
        ([{"handles": [{"indices": [1]}]}, {"continues": True, "roi": [2], "handles": [{}]}], "give either"),
        ([{"handles": [{"indices": [1]}]}, {"continues": True, "handles": [{"indices": [2]}]}], "gives \"indices\""),
        ([{"handles": [{"indices": [1]}], "iterations": -1}], "whole number"),
        ([{"handles": [{"indices": [1]}], "polish": 2.5}], "whole number"),
        ([{"handles": [{"indices": [1]}], "cage": {"size": 0.05}}], '"steps[0].cage"'),
        ([{"handles": [{"indices": [1]}], "grip": 1}], 'unknown keys in "steps[0]"'),
        ([{"handles": [{"indices": [1]}]}, {"handles": [{"indices": [2], "spin": 1}]}], '"steps[1].handles[0]"'),
        ([{"handles": [{"indices": [1]}], "roi": [2], "fixed": [3]}], "not both"),
        ([3], "must be an object"),
    ],
)
def test_bad_version_3_files(tmp_path, steps, words):
    p = tmp_path / "bad3.json"
    p.write_text(json.dumps({"format": "hybridedit-edit", "version": 3, "steps": steps}))
    with pytest.raises(EditFileError) as err:
        load_edit(p)
    msg = str(err.value)
    assert msg.startswith(str(p)) and words in msg and "\n" not in msg


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


def test_kept_poses_round_trip_beside_the_edit_and_load_edit_reads_the_edit_alone(tmp_path, blob):
    """Poses kept beside the edit (the window's Poses panel): each a name and steps from the rest pose,
    read back with the file's fingerprint; load_edit (hybridedit deform) reads the file's own steps."""
    from hybridedit.fileio.editfile import HandleEdit, edit_json, load_edit_with_poses, mesh_fingerprint

    fp = mesh_fingerprint(blob)
    now = Edit(handles=[HandleEdit(np.array([8]), translate=np.array([0, 0.1, 0]))], roi=np.arange(20),
               iterations=60, mesh=fp)
    up = Edit(handles=[HandleEdit(np.array([3, 4]), translate=np.array([0, 0.3, 0]))], roi=np.arange(9),
              iterations=60, polish=12)
    on = Edit(handles=[HandleEdit(up.handles[0].indices, translate=np.array([0.2, 0, 0]))], roi=up.roi,
              continues=True, iterations=60, before=[up])
    p = tmp_path / "kept.json"
    save_edit(p, now, poses=[("arm up", up), ("arm up, then out", on)])
    data = json.loads(p.read_text())
    assert [k["name"] for k in data["poses"]] == ["arm up", "arm up, then out"]
    assert len(data["poses"][1]["steps"]) == 2 and "mesh" not in data["poses"][0]
    plain = load_edit(p)
    assert len(plain.steps) == 1 and plain.handles[0].indices.tolist() == [8]
    edit, poses = load_edit_with_poses(p)
    assert np.allclose(edit.translate, [0, 0.1, 0]) and [n for n, _ in poses] == ["arm up", "arm up, then out"]
    (_, a), (_, b) = poses
    assert a.mesh == fp and b.mesh == fp and a.polish == 12 and len(b.steps) == 2 and b.continues
    assert b.handles[0].indices.tolist() == [3, 4] and np.allclose(b.translate, [0.2, 0, 0])
    # a file without poses: none, and the same JSON as before there were poses
    save_edit(p, now)
    assert "poses" not in json.loads(p.read_text()) and load_edit_with_poses(p)[1] == []
    assert edit_json(now) == now.to_json()
    with pytest.raises(ValueError, match="unique"):
        save_edit(p, now, poses=[("a", up), ("a", on)])


STEP = {"handles": [{"indices": [1]}]}


@pytest.mark.parametrize(
    "poses, words",
    [
        ({"name": "a"}, '"poses" must be a list'),
        ([3], '"poses[0]" must be an object'),
        ([{"name": "", "steps": [STEP]}], '"poses[0].name" must be a non-empty text'),
        ([{"name": 5, "steps": [STEP]}], '"poses[0].name"'),
        ([{"name": "a", "steps": [STEP]}, {"name": "a", "steps": [STEP]}], "given twice"),
        ([{"name": "a", "steps": []}], '"poses[0].steps" must be a non-empty list'),
        ([{"name": "a", "steps": [STEP], "look": 1}], 'unknown keys in "poses[0]"'),
        ([{"name": "a", "steps": [{"continues": True, "handles": [{}]}]}], '"poses[0].steps[0]" cannot continue'),
        ([{"name": "a", "steps": [{"handles": [{"indices": [1], "spin": 3}]}]}], '"poses[0].steps[0].handles[0]"'),
    ],
)
def test_bad_kept_poses_name_the_file_and_where(tmp_path, poses, words):
    from hybridedit.fileio.editfile import load_edit_with_poses

    p = tmp_path / "bad.json"
    p.write_text(json.dumps({"format": "hybridedit-edit", "version": 3, "steps": [STEP], "poses": poses}))
    assert load_edit(p).handles[0].indices.tolist() == [1]  # (the file's own pose still replays)
    with pytest.raises(EditFileError) as err:
        load_edit_with_poses(p)
    msg = str(err.value)
    assert msg.startswith(str(p)) and words in msg and "\n" not in msg
