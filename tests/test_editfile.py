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
