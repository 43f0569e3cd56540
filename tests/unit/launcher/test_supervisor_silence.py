"""The handover job's judgement of a silent supervisor (services/launcher/supervisor_silence.py):
the watch starts with the first episode, a silence past `SUPERVISOR_SILENT_S` stops the arm
unless starvation excuses it (up to `MAX_EXCUSED_S`), a stopped process is silent at once."""

from __future__ import annotations

import pytest

from services.launcher.supervisor_silence import (
    NOTE_AFTER_S,
    STOPPED_AFTER_S,
    SUPERVISOR_SILENT_S,
    SIM_WALL_GRACE_S,
    SilenceVerdict,
    SimClockSilence,
    SupervisorSilence,
)
from services.runtime.sched import MAX_EXCUSED_S

SUPERVISOR_PID, ROUTER_PID, OWN_PID = 11, 22, 33


class _Clock:
    def __init__(self) -> None:
        self.now_s = 100.0

    def __call__(self) -> float:
        return self.now_s


class _Judge:
    """A starvation judge with set answers; records what it was asked."""

    def __init__(self, excuse: str | None = None, path: str | None = None, stopped_now: bool = False,
                 stopped: bool = False) -> None:
        self._excuse, self._path, self._stopped_now, self._stopped = excuse, path, stopped_now, stopped
        self.noted: list[tuple[int, float, float | None]] = []
        self.ticks: list[float] = []
        self.path_asked: list[tuple[int, ...]] = []

    def tick(self, now_s: float) -> None:
        self.ticks.append(now_s)

    def note(self, pid: int, now_s: float, quiet_since_s: float | None = None) -> None:
        self.noted.append((pid, now_s, quiet_since_s))

    def is_stopped_now(self, pid: int, now_s: float) -> bool:
        return self._stopped_now

    def stopped(self, pid: int, now_s: float) -> bool:
        return self._stopped

    def excuse(self, pid: int, now_s: float) -> str | None:
        return self._excuse

    def excuse_path(self, pids: tuple[int, ...], now_s: float) -> str | None:
        self.path_asked.append(pids)
        return self._path


def _silence(judge: _Judge | None = None, one_host: bool = True) -> tuple[SupervisorSilence, _Clock]:
    clock = _Clock()
    silence = SupervisorSilence((lambda: SUPERVISOR_PID) if one_host else None, (ROUTER_PID, OWN_PID),
                                judge=judge, clock=clock)
    return silence, clock


def _heard_in_episode(silence: SupervisorSilence, clock: _Clock, silent_s: float, episode: int = 1) -> float:
    silence.heard(clock.now_s, episode)
    clock.now_s += silent_s
    return silence.silent_s()


def test_no_silence_before_the_first_state_or_before_episode_1():
    silence, clock = _silence(_Judge())
    assert silence.silent_s() == 0.0
    assert _heard_in_episode(silence, clock, 5.0, episode=0) == 0.0
    assert silence.judge(silence.silent_s()) == SilenceVerdict()
    assert _heard_in_episode(silence, clock, 0.5, episode=1) == pytest.approx(0.5)
    silence.heard(clock.now_s, 0)  # a later state of episode 0 does not end the watch
    assert silence.episode_begun


def test_a_short_silence_goes_on_without_reading_the_processes():
    judge = _Judge()
    silence, clock = _silence(judge)
    assert silence.judge(_heard_in_episode(silence, clock, NOTE_AFTER_S / 2)) == SilenceVerdict()
    assert judge.noted == []


def test_a_quiet_supervisor_and_its_delivery_path_are_noted_from_their_last_state():
    judge = _Judge()
    silence, clock = _silence(judge)
    heard_s = clock.now_s
    assert silence.judge(_heard_in_episode(silence, clock, (NOTE_AFTER_S + STOPPED_AFTER_S) / 2)) == SilenceVerdict()
    assert judge.noted == [(pid, clock.now_s, heard_s) for pid in (SUPERVISOR_PID, ROUTER_PID, OWN_PID)]


def test_a_stopped_supervisor_is_silent_before_the_silence_limit():
    silence, clock = _silence(_Judge(excuse="starved", stopped_now=True))
    verdict = silence.judge(_heard_in_episode(silence, clock, (STOPPED_AFTER_S + SUPERVISOR_SILENT_S) / 2))
    assert verdict.stop_reason is not None and verdict.line is None
    assert verdict.stop_reason.startswith("supervisor: silent: no supervisor/state for ")
    assert verdict.stop_reason.endswith(" s, its process is stopped; the launcher stopped the arm")


def test_a_silence_past_the_limit_not_excused_stops_the_arm():
    silence, clock = _silence(_Judge())
    silent_s = _heard_in_episode(silence, clock, SUPERVISOR_SILENT_S + 0.05)
    assert silence.judge(silent_s).stop_reason == (f"supervisor: silent: no supervisor/state for {silent_s:.3f} s; "
                                                   "the launcher stopped the arm")


def test_a_starved_supervisor_is_excused_and_said_at_most_every_five_seconds():
    silence, clock = _silence(_Judge(excuse="run queue 80 %"))
    silent_s = _heard_in_episode(silence, clock, SUPERVISOR_SILENT_S + 0.05)
    first = silence.judge(silent_s)
    assert first.stop_reason is None
    assert first.line == (f"supervisor: no supervisor/state for {silent_s:.3f} s, "
                          "excused: starved of CPU (run queue 80 %)")
    clock.now_s += 0.1
    assert silence.judge(silence.silent_s()) == SilenceVerdict()  # excused again, not said again
    clock.now_s += 5.0  # heard from again in between, then silent again
    assert silence.judge(_heard_in_episode(silence, clock, SUPERVISOR_SILENT_S + 0.05)).line is not None


def test_a_starved_delivery_path_excuses_the_silence():
    judge = _Judge(path="the delivery path was starved: pid 22: waited")
    silence, clock = _silence(judge)
    verdict = silence.judge(_heard_in_episode(silence, clock, SUPERVISOR_SILENT_S + 0.05))
    assert verdict.stop_reason is None and verdict.line is not None and "pid 22" in verdict.line
    assert judge.path_asked == [(ROUTER_PID, OWN_PID)]


def test_no_excuse_past_the_longest_excused_silence_nor_for_a_stopped_process():
    silence, clock = _silence(_Judge(excuse="starved"))
    assert silence.judge(_heard_in_episode(silence, clock, MAX_EXCUSED_S + 0.1)).stop_reason is not None
    silence, clock = _silence(_Judge(excuse="starved", stopped=True))
    assert silence.judge(_heard_in_episode(silence, clock, SUPERVISOR_SILENT_S + 0.05)).stop_reason is not None


def test_without_the_supervisors_pid_no_silence_is_excused_and_no_judge_runs():
    silence, clock = _silence(None, one_host=False)
    silence.tick(clock.now_s)  # no judge: nothing to keep
    assert silence.judge(_heard_in_episode(silence, clock, NOTE_AFTER_S + 0.05)) == SilenceVerdict()
    assert silence.judge(_heard_in_episode(silence, clock, SUPERVISOR_SILENT_S + 0.05)).stop_reason is not None


def test_the_supervisor_gone_from_the_children_is_judged_without_excuse():
    judge = _Judge(excuse="starved")
    clock = _Clock()
    silence = SupervisorSilence(lambda: None, (ROUTER_PID,), judge=judge, clock=clock)
    silence.tick(clock.now_s)
    assert judge.ticks == [clock.now_s]
    assert silence.judge(_heard_in_episode(silence, clock, SUPERVISOR_SILENT_S + 0.05)).stop_reason is not None
    assert judge.noted == []


# --- on the simulation clock: the silence is counted in the stack's time ----------------------

def _sim_silence() -> tuple[SimClockSilence, _Clock]:
    wall = _Clock()
    silence = SimClockSilence(clock=wall)
    silence.heard(wall.now_s, 1, stamp_s=5.0)
    return silence, wall


def test_on_the_sim_clock_a_slow_stack_is_never_silent():
    """Minutes of wall time with no state are no silence while the stack's time stands still
    (a busy machine slows the clock, whose steps wait for the supervisor)."""
    silence, wall = _sim_silence()
    wall.now_s += 120.0
    silence.saw_stack_time(5.01)
    assert silence.silent_s() == pytest.approx(0.01)
    assert silence.judge(silence.silent_s()) == SilenceVerdict()


def test_on_the_sim_clock_a_supervisor_left_behind_stops_the_arm_in_stack_time():
    silence, wall = _sim_silence()
    wall.now_s += 0.06
    silence.saw_stack_time(5.0 + SUPERVISOR_SILENT_S - 0.01)
    assert silence.judge(silence.silent_s()).stop_reason is None
    silence.saw_stack_time(5.0 + SUPERVISOR_SILENT_S + 0.05)
    verdict = silence.judge(silence.silent_s())
    assert verdict.stop_reason is not None and "0.250 s of simulated time" in verdict.stop_reason


def test_on_the_sim_clock_a_state_that_trails_other_senders_by_milliseconds_is_waited_for():
    """Zenoh orders samples per sender: a state may arrive a few ms after later truth."""
    silence, wall = _sim_silence()
    wall.now_s += SIM_WALL_GRACE_S / 2
    silence.saw_stack_time(6.0)
    assert silence.silent_s() == 0.0
    wall.now_s += SIM_WALL_GRACE_S
    assert silence.silent_s() == pytest.approx(1.0)


def test_on_the_sim_clock_the_watch_starts_with_the_first_episode_and_older_stamps_do_not_move_time_back():
    wall = _Clock()
    silence = SimClockSilence(clock=wall)
    silence.heard(wall.now_s, 0, stamp_s=1.0)
    silence.saw_stack_time(9.0)
    wall.now_s += 1.0
    assert silence.silent_s() == 0.0  # episode 0: before the first episode
    silence.heard(wall.now_s, 1, stamp_s=9.5)
    silence.saw_stack_time(9.2)  # a late, older stamp
    wall.now_s += 1.0
    assert silence.stack_now_s == 9.5 and silence.silent_s() == 0.0
