"""Tests for hybridedit.fileio.formats.reporting: progress of reading and writing files."""

import pytest

from hybridedit.fileio.formats.reporting import report, reporting, span


def test_spans_nest_and_fractions_are_clamped():
    seen = []
    with reporting(seen.append):
        report(0.0)
        with span(0.2, 0.6):
            report(0.5)  # 0.2 + 0.4 * 0.5
            with span(0.5, 1.0):
                report(1.0)  # the end of the outer span
        report(2.0)  # clamped
    assert seen == pytest.approx([0.0, 0.4, 0.6, 1.0])


def test_without_a_callback_nothing_happens_and_the_range_is_restored():
    report(0.5)  # no callback installed: nothing to do
    seen = []
    with reporting(seen.append):
        with span(0.5, 1.0):
            pass
        report(0.25)
    assert seen == [0.25]


def test_an_exception_from_the_callback_reaches_the_caller():
    class Stop(Exception):
        pass

    def cancel(_fraction):
        raise Stop

    with pytest.raises(Stop), reporting(cancel):
        report(0.5)
    report(0.5)  # and the callback is gone afterwards
