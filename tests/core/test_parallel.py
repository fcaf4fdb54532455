import pytest

from hybridedit.core import parallel


def test_pick_switches_at_the_kinds_size_and_all_parallel_restores_it():
    size = parallel.THRESHOLDS["propagate"]
    assert parallel.pick("propagate", "s", "p", size - 1) == "s"
    assert parallel.pick("propagate", "s", "p", size) == "p"
    with parallel.all_parallel():
        assert all(v == 0 for v in parallel.THRESHOLDS.values())
        assert parallel.pick("propagate", "s", "p", 0) == "p"
    assert parallel.THRESHOLDS["propagate"] == size
    with pytest.raises(KeyError):
        parallel.pick("no such kind", "s", "p", 1)
