"""The limb skeleton (hybridedit.deform.skeleton): centre, extremities by geodesic farthest points,
and the joint where a limb's region meets the rest."""

from __future__ import annotations

import numpy as np

from hybridedit.deform.skeleton import MAX_EXTREMITIES, MIN_SPREAD, find_skeleton, joint_centre


def star(arms: int, length: float = 1.0, steps: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """A centre vertex (0) with ``arms`` straight arms of ``steps`` edges each, in the xy plane."""
    v, e = [np.zeros(3)], []
    for a in range(arms):
        d = np.array([np.cos(2 * np.pi * a / arms), np.sin(2 * np.pi * a / arms), 0.0])
        prev = 0
        for s in range(1, steps + 1):
            v.append(d * length * s / steps)
            e.append([prev, len(v) - 1])
            prev = len(v) - 1
    return np.array(v), np.array(e)


def test_each_arm_tip_is_an_extremity_and_nothing_short_of_the_spread_is():
    v, e = star(5, steps=4)
    s = find_skeleton(v, e, centre_point=np.zeros(3))
    tips = {4 * a + 4 for a in range(5)}
    # the five tips, then points half way along an arm (0.5 of the reach, over MIN_SPREAD = 0.3)
    assert set(s.extremities[:5].tolist()) == tips and s.centre == 0
    assert np.allclose(s.reach[:5], 1.0) and len(s.extremities) <= MAX_EXTREMITIES
    for k in range(1, len(s.extremities)):  # each one at least MIN_SPREAD from the centre and those before
        x = s.extremities[k]
        assert min(s.reach[k], s.distances[:k, x].min()) >= MIN_SPREAD * s.reach[0] - 1e-12
    assert np.allclose(s.distances[np.arange(len(s.extremities)), s.extremities], 0.0)


def test_a_cage_in_two_parts_keeps_to_the_centres_part():
    v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [10, 0, 0], [11, 0, 0]], dtype=float)
    s = find_skeleton(v, np.array([[0, 1], [1, 2], [3, 4]]), centre_point=np.zeros(3))
    assert s.centre == 0 and s.extremities[0] == 2 and np.isinf(s.distances[:, 3:]).all()
    assert set(s.extremities.tolist()) <= {1, 2}  # none on the other part


def test_a_single_vertex_has_no_extremity():
    s = find_skeleton(np.zeros((1, 3)), np.zeros((0, 2), dtype=np.int64), centre_point=np.ones(3))
    assert s.centre == 0 and s.extremities.size == 0 and s.distances.shape == (0, 1)


def test_the_joint_is_the_middle_of_the_regions_border():
    v, e = star(2, length=4.0, steps=4)  # a stick from -4 to 4 along x, vertex 0 at 0
    region = v[:, 0] > 1.5  # x = 2, 3, 4: its border is the vertex at x = 2
    assert np.allclose(joint_centre(region, e, v), [2.0, 0, 0])
    both = np.abs(v[:, 0]) > 1.5  # the two ends: the border is at x = 2 and x = -2
    assert np.allclose(joint_centre(both, e, v), [0.0, 0, 0])
    assert joint_centre(np.ones(len(v), bool), e, v) is None  # the whole part has no border
