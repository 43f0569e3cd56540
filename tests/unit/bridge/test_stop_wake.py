"""The bridge's loop clock wakes at once for a stop and keeps its 100 Hz grid; the bridge's
config: the Kinect moved out, the scene receiver's body stays."""

from __future__ import annotations

import threading
import time

import pytest

from services.bridge.backend import make_backend
from services.bridge.cli import main as bridge_main
from services.bridge.config import ContactConfig, parse_config
from services.bridge.errors import BridgeConfigError
from services.bridge.ticker import StopTicker


class FakeNode:
    """The part of `ServiceNode` the ticker uses: `wait` woken by `notify`, and stopping."""

    def __init__(self) -> None:
        self.stop_event = threading.Event()
        self._cond = threading.Condition()
        self._new = False

    @property
    def should_stop(self) -> bool:
        return self.stop_event.is_set()

    def notify(self) -> None:
        with self._cond:
            self._new = True
            self._cond.notify_all()

    def wait(self, timeout_s: float) -> bool:
        with self._cond:
            if not self._new and not self.stop_event.is_set():
                self._cond.wait(timeout_s)
            got, self._new = self._new, False
        return got


def _run(ticker: StopTicker, node: FakeNode, pending: list[bool], stop_after: int, notify_at_tick: int,
         also_unrelated: bool = False) -> list[tuple[bool, float]]:
    """Iterate `ticker`; after grid tick `notify_at_tick` another thread raises a stop (and
    before it, optionally, an unrelated message). Returns (urgent, time) per tick."""
    ticks: list[tuple[bool, float]] = []
    grid = 0
    for urgent in ticker:
        ticks.append((urgent, time.monotonic()))
        if urgent:
            pending[0] = False  # the tick drained the stop
            continue
        grid += 1
        if grid == notify_at_tick:
            def raise_stop() -> None:
                if also_unrelated:
                    node.notify()  # e.g. a joint command: wakes, but is not urgent
                    time.sleep(0.002)
                time.sleep(0.003)
                pending[0] = True
                node.notify()
            threading.Thread(target=raise_stop).start()
        if grid >= stop_after:
            node.stop_event.set()
    return ticks


@pytest.mark.parametrize("also_unrelated", [False, True])
def test_a_stop_runs_one_extra_tick_between_grid_ticks(also_unrelated):
    node = FakeNode()
    pending = [False]
    ticker = StopTicker(node, 50.0, lambda: pending[0])
    ticks = _run(ticker, node, pending, stop_after=6, notify_at_tick=3, also_unrelated=also_unrelated)
    kinds = [u for u, _ in ticks]
    assert kinds == [False, False, False, True, False, False, False]  # extra tick after the 3rd grid tick
    assert ticker.stats.urgent_ticks == 1 and ticker.stats.ticks == 6
    # The grid is kept: the extra tick did not move the following grid ticks.
    grid_times = [t for u, t in ticks if not u]
    assert grid_times[3] - grid_times[0] == pytest.approx(3 * 0.02, abs=0.015)


def test_a_flood_of_stops_runs_at_most_one_extra_tick_per_period():
    node = FakeNode()
    ticker = StopTicker(node, 50.0, lambda: True)  # a stop is always pending
    kinds = []
    for urgent in ticker:
        kinds.append(urgent)
        node.notify()  # and another one arrives at once
        if kinds.count(False) >= 4:
            node.stop_event.set()
    assert kinds == [False, True, False, True, False, True, False]


def test_without_urgent_the_stop_waits_for_the_grid():
    node = FakeNode()
    pending = [False]
    ticker = StopTicker(node, 50.0, None)
    ticks = _run(ticker, node, pending, stop_after=5, notify_at_tick=2)
    assert all(not u for u, _ in ticks) and ticker.stats.urgent_ticks == 0


def test_the_kinect_table_moved_out_of_the_bridge():
    with pytest.raises(BridgeConfigError, match=r"services\.kinect\.config"):
        parse_config({"kinect": {"enabled": True}})
    assert parse_config({}).stop_wakes_loop


def test_the_scene_receivers_body_comes_from_the_contact_table():
    backend = make_backend("sim", contact=ContactConfig(enabled=True, scenario="handover", posture="sitting",
                                                       height_m=1.6))
    size = backend.scene.body.size
    assert (size.posture, size.height_m) == ("sitting", 1.6)


def test_bridge_cli_no_longer_takes_kinect_flags(capsys):
    with pytest.raises(SystemExit) as exc:
        bridge_main(["--kinect"])
    assert exc.value.code == 2
    assert "--kinect" in capsys.readouterr().err
