"""Tests for hybridedit.core.progress: the time-left estimate and its text rendering."""

from __future__ import annotations

import io

import pytest

from hybridedit.core.progress import StepTimer, TextProgress, format_seconds


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_steady_step_estimates_the_time_left():
    clock = Clock()
    timer = StepTimer(clock)
    r = timer.update("binding", 0.0)
    assert r.elapsed == 0 and r.remaining is None and not r.done
    clock.t += 2.0
    r = timer.update("binding", 0.25)  # 2 s for a quarter: 6 s left
    assert r.remaining == pytest.approx(6.0)
    assert r.text() == "binding 25%, about 6 s left"
    clock.t += 4.0
    r = timer.update("binding", 0.75)
    assert r.remaining == pytest.approx(2.0)
    clock.t += 2.0
    r = timer.update("binding", 1.0)
    assert r.done and r.remaining is None and r.elapsed == pytest.approx(8.0)
    assert r.text() == "binding done (8.00 s)" and r.eta_text() == ""


def test_no_estimate_from_too_little():
    clock = Clock()
    timer = StepTimer(clock)
    timer.update("cage", 0.0)
    clock.t += 0.1
    assert timer.update("cage", 0.5).remaining is None  # too early
    clock.t += 5.0
    timer2 = StepTimer(clock)
    timer2.update("bind", 0.3)
    clock.t += 5.0
    assert timer2.update("bind", 0.31).remaining is None  # too little progress


def test_a_step_that_starts_part_done_counts_from_its_first_report():
    clock = Clock()
    timer = StepTimer(clock)
    timer.update("polish", 0.5)
    clock.t += 1.0
    assert timer.update("polish", 0.6).remaining == pytest.approx(4.0)


def test_set_up_before_the_first_progress_does_not_count_in_the_rate():
    # the binding's plan takes 10 s and reports 0 again when it is done; then 1 s per 10%
    clock = Clock()
    timer = StepTimer(clock)
    timer.update("binding", 0.0)
    clock.t += 10.0
    timer.update("binding", 0.0)
    clock.t += 1.0
    r = timer.update("binding", 0.1)
    assert r.remaining == pytest.approx(9.0)  # not 99 s
    assert r.elapsed == pytest.approx(11.0)  # the step's own time still counts from its start


def test_a_new_step_restarts_the_clock_and_bad_fractions_are_clamped():
    clock = Clock()
    timer = StepTimer(clock)
    timer.update("reading", 0.0)
    clock.t += 3.0
    timer.update("reading", 1.0)
    r = timer.update("cage", float("nan"))
    assert r.elapsed == 0 and r.fraction == 0.0
    assert timer.update("cage", 7.0).fraction == 1.0
    clock.t += 1.0
    assert timer.update("cage", 0.1).elapsed == 0  # the same name after done is a new step


def test_worth_showing_only_steps_over_a_second():
    clock = Clock()
    timer = StepTimer(clock)
    timer.update("write", 0.0)
    clock.t += 0.6
    quick = timer.update("write", 0.9)  # 0.6 s for 90%: ends at about 0.67 s
    assert not quick.worth_showing()
    timer.update("bind", 0.0)
    clock.t += 0.6
    slow = timer.update("bind", 0.1)  # expected to take 6 s
    assert slow.worth_showing() and slow.remaining == pytest.approx(5.4)
    clock.t += 0.6
    assert timer.update("bind", 0.1).worth_showing()  # over a second anyway


@pytest.mark.parametrize("seconds, text", [(0.2, "1 s"), (12.4, "12 s"), (60, "1 min"), (125, "2 min 5 s"),
                                           (3725, "1 h 2 min")])
def test_format_seconds(seconds, text):
    assert format_seconds(seconds) == text


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_terminal_line_shows_the_time_left_and_ends_clean():
    clock = Clock()
    out = Tty()
    say = TextProgress(stream=out, clock=clock)
    say("binding", 0.0)
    clock.t += 2.0
    say("binding", 0.5)
    clock.t += 2.0
    say("binding", 1.0)
    text = out.getvalue()
    assert "\rhybridedit: binding  50% (about 2 s left)" in text
    # the final line wipes the longer one before it
    assert text.endswith("\r" + " " * len("hybridedit: binding  50% (about 2 s left)") + "\rhybridedit: binding 100%\n")


def test_log_gets_a_start_and_a_done_line_and_quiet_nothing():
    clock = Clock()
    out = io.StringIO()
    say = TextProgress(stream=out, clock=clock)
    say("reading a.ply", 0.0)
    clock.t += 1.5
    say("reading a.ply", 1.0)
    say("read a.ply: 8 vertices")
    assert out.getvalue().splitlines() == ["hybridedit: reading a.ply ...", "hybridedit: reading a.ply done (1.50 s)",
                                           "hybridedit: read a.ply: 8 vertices"]
    quiet = io.StringIO()
    q = TextProgress(True, quiet)
    q("x", 0.5)
    q("y")
    assert quiet.getvalue() == ""


def test_an_end_reported_twice_is_said_once():
    # the cage builder reports its end, and so does the step around it
    clock = Clock()
    out = io.StringIO()
    say = TextProgress(stream=out, clock=clock)
    say("building the cage", 0.0)
    clock.t += 1.25
    say("building the cage", 1.0)
    say("building the cage", 1.0)
    say("binding", 0.0)
    say("binding", 1.0)
    say("binding", 0.0)  # the same name again, from the start: a new step
    say("binding", 1.0)
    assert out.getvalue().splitlines() == [
        "hybridedit: building the cage ...", "hybridedit: building the cage done (1.25 s)",
        "hybridedit: binding ...", "hybridedit: binding done (0.00 s)",
        "hybridedit: binding ...", "hybridedit: binding done (0.00 s)"]


def test_a_step_stopped_midway_has_its_line_ended_before_anything_else():
    clock = Clock()
    out = Tty()
    say = TextProgress(stream=out, clock=clock)
    say.end_line()  # nothing open: nothing printed
    assert out.getvalue() == ""
    say("reading a.obj", 0.0)
    clock.t += 1.0
    say("reading a.obj", 0.4)
    assert not out.getvalue().endswith("\n")  # the line updates in place
    say("a note")  # a message during the step starts a line of its own
    assert out.getvalue().endswith("40% (about 1 s left)\nhybridedit: a note\n")
    say("binding", 0.2)
    say.end_line()  # e.g. an error stopped the step: what follows starts on its own line
    say.end_line()  # (once)
    assert out.getvalue().endswith("binding  20%\n")
    say("binding", 1.0)
    assert out.getvalue().endswith("\rhybridedit: binding 100%\n")
