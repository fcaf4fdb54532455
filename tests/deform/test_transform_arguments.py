"""A drag's transform arguments as each handle group's 4x4 (hybridedit.deform.transform_arguments)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from hybridedit import SelectionError
from hybridedit.core.transforms import apply_transform, rigid_transform
from hybridedit.deform.transform_arguments import group_transform, requested_transforms

CENTER = np.array([1.0, -2.0, 0.5])


def test_the_three_forms_of_a_rotation_are_one_transform_about_the_default_centre():
    R = Rotation.from_rotvec(np.radians(30) * np.array([0.0, 0.0, 1.0]))
    expect = rigid_transform(axis=(0, 0, 1), degrees=30, center=CENTER)
    for rotate in (R, R.as_matrix(), {"axis": (0, 0, 1), "degrees": 30}):
        T = group_transform(None, rotate, None, center=CENTER)
        assert np.allclose(T, expect, atol=1e-12)
        assert np.allclose(apply_transform(T, CENTER[None]), CENTER[None])  # the centre stays


def test_a_centre_given_with_the_rotation_wins_and_translate_comes_after_it():
    rotate = {"axis": (1, 0, 0), "degrees": 45, "center": (0.0, 0.0, 0.0)}
    T = group_transform((0.0, 3.0, 0.0), rotate, None, center=CENTER)
    expect = rigid_transform(translate=(0.0, 3.0, 0.0)) @ rigid_transform(axis=(1, 0, 0), degrees=45)
    assert np.allclose(T, expect, atol=1e-12)
    assert np.array_equal(group_transform(None, None, None, center=CENTER), np.eye(4))


@pytest.mark.parametrize("rotate", [np.diag([1.0, 1.0, -1.0]), 2 * np.eye(3), np.eye(4), [[np.nan] * 3] * 3])
def test_a_matrix_that_is_no_rotation_is_refused(rotate):
    with pytest.raises(ValueError, match="rotate must be a 3x3 rotation matrix"):
        group_transform(None, rotate, None, center=CENTER)


def test_transform_with_translate_or_rotate_is_refused():
    with pytest.raises(ValueError, match="not both"):
        group_transform((1.0, 0, 0), None, np.eye(4), center=CENTER)
    with pytest.raises(ValueError, match="4x4"):
        group_transform(None, None, np.eye(3), center=CENTER)


def test_requested_transforms_set_one_group_or_several_and_keep_the_others():
    current = [np.eye(4), rigid_transform(translate=(1.0, 0, 0))]
    centers = [np.zeros(3), CENTER]
    moved = rigid_transform(translate=(0, 0, 2.0))
    one = requested_transforms(current, centers, translate=(0, 0, 2.0), rotate=None, transform=None, group=0,
                               transforms=None)
    assert np.allclose(one[0], moved) and np.array_equal(one[1], current[1])
    turned = requested_transforms(current, centers, translate=None, rotate={"axis": (0, 0, 1), "degrees": 90},
                                  transform=None, group=1, transforms=None)
    assert np.allclose(turned[1], rigid_transform(axis=(0, 0, 1), degrees=90, center=CENTER))
    both = requested_transforms(current, centers, translate=None, rotate=None, transform=None, group=0,
                                transforms={np.int64(1): moved})
    assert np.array_equal(both[0], current[0]) and np.array_equal(both[1], moved)
    assert len(current) == 2 and np.array_equal(current[0], np.eye(4))  # the input list is not changed


@pytest.mark.parametrize("kw", [dict(group=2), dict(group=-1), dict(group=1.0), dict(transforms={3: np.eye(4)})])
def test_a_group_the_selection_does_not_have_is_a_selection_error(kw):
    args = dict(translate=None, rotate=None, transform=None, group=0, transforms=None) | kw
    if "transforms" not in kw:
        args["translate"] = (1.0, 0, 0)
    with pytest.raises(SelectionError, match="no handle group"):
        requested_transforms([np.eye(4), np.eye(4)], [np.zeros(3)] * 2, **args)


def test_transforms_with_one_groups_arguments_is_refused():
    with pytest.raises(ValueError, match="give transforms, or one group's"):
        requested_transforms([np.eye(4)], [np.zeros(3)], translate=(1.0, 0, 0), rotate=None, transform=None,
                             group=0, transforms={0: np.eye(4)})
