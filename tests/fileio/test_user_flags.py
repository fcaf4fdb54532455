"""The user's one-time flags (hybridedit.fileio.user_flags): set for good, kept beside the up axes."""

from __future__ import annotations

from hybridedit.fileio.user_flags import FILE_NAME, flag_set, set_flag


def test_a_flag_set_stays_set_and_leaves_the_others_alone(tmp_path):
    assert not flag_set("a", folder=tmp_path)
    assert set_flag("a", folder=tmp_path) and set_flag("b", folder=tmp_path)
    assert flag_set("a", folder=tmp_path) and flag_set("b", folder=tmp_path) and not flag_set("c", folder=tmp_path)
    assert (tmp_path / FILE_NAME).read_text().split() == ['[', '"a",', '"b"', ']']


def test_a_damaged_file_or_a_folder_that_cannot_be_written_sets_nothing(tmp_path):
    (tmp_path / FILE_NAME).write_text("{not json")
    assert not flag_set("a", folder=tmp_path)
    assert set_flag("a", folder=tmp_path) and flag_set("a", folder=tmp_path)  # written again, whole
    blocked = tmp_path / "file"
    blocked.write_text("")
    assert not set_flag("a", folder=blocked / "cache")  # (a file where the folder should be)
