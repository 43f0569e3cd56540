"""Release interrupt latency with the whole stack as real processes: a release event while
the arm is MOVING → the arm at rest.

In the normal handover the arm is already at rest when the gripper releases, so the test
makes the release come during the reach: `handover-up --job none --episodes N --receiver
absent` runs N episodes back to back (the scene resets the object on the table at every new
episode); in each, once the supervisor is in ``reach`` and the arm moves faster than
`MOVING_RAD_S`, the test publishes a `gripper/release` (ReleaseEvent) and measures from just
before that publication to the first `robot/joint_state` with every |v| < 0.01 rad/s
(received by the test). It also records when the supervisor's `motion/stop` and its
``released`` state arrived, to split the latency into reaction and braking.
"""

from __future__ import annotations

import os
import random
import shutil
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from bus_schema import topics
from services.launcher.logins import login_profile
from services.runtime import ServiceNode
from services.runtime.profile import free_tcp_port
from services.runtime.testing import loopback_profile
from tests.faults.harness import REPO, _owned
from tests.faults.invariants import REST_SPEED_RAD_S

#: The release is sent once the arm moves at least this fast (max joint speed), rad/s.
MOVING_RAD_S = 0.2


@dataclass
class ReleaseSample:
    """One release interrupt (s, test monotonic differences)."""

    episode_id: int
    speed_at_release_rad_s: float
    event_to_stop_s: float | None
    event_to_released_state_s: float | None
    event_to_rest_s: float | None
    #: The same three by the senders' stamps (`stamp_ns`, one host clock): when the supervisor
    #: sent its stop and its ``released`` state and when the bridge published the first joint
    #: state at rest, from the release event's publication. The observer's own receive delay
    #: (this test process starved of CPU) is not in these.
    stamp_event_to_stop_s: float | None = None
    stamp_event_to_released_state_s: float | None = None
    stamp_event_to_rest_s: float | None = None


def measure_release_interrupts(episodes: int, seed: int = 0, timeout_s: float = 600.0,
                               protective_stops_out: list[str] | None = None) -> list[ReleaseSample]:
    """Run `episodes` episodes and interrupt each reach with a release (see module docstring).
    A protective stop (e.g. a watchdog time-out on an overloaded machine) ends the stack
    early: its reason is appended to `protective_stops_out`."""
    port = free_tcp_port()
    profile = loopback_profile(port)
    rng = random.Random(seed)
    workdir = Path(os.environ.get("TMPDIR", "/tmp"))
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("HANDOVER_FAULTS", None)
    proc = subprocess.Popen(
        [sys.executable, "-m", "services.launcher", "--port", str(port), "--job", "none", "--receiver", "absent",
         "--episodes", str(episodes), "--seed", str(seed), "--recording-dir", str(workdir), "--run-id",
         f"release-bench-{port}"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True, env=env, cwd=REPO,
        start_new_session=True,
    )
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout or []), daemon=True)
    reader.start()
    samples: list[ReleaseSample] = []
    node: ServiceNode | None = None
    try:
        # The release event comes as from the gripper, with its login of the run.
        node = ServiceNode("gripper", login_profile(profile, workdir, f"release-bench-{port}", "gripper"),
                           install_signal_handlers=False, connect_timeout_s=30.0)
        node.open()
        states = node.subscribe(topics.SUPERVISOR_STATE, 10_000)
        joints = node.subscribe(topics.JOINT_STATE, 10_000)
        stops = node.subscribe(topics.MOTION_STOP, 1000)
        release_pub = node.publisher(topics.GRIPPER_RELEASE)
        deadline = time.monotonic() + timeout_s
        phase, episode_id, reach_since = "idle", 0, None
        wait_after_reach_s = 0.0
        pending: dict | None = None
        done_episodes: set[int] = set()
        protective_stops: list[str] = []
        while time.monotonic() < deadline and len(done_episodes) < episodes and proc.poll() is None:
            node.wait(0.001)
            for rx in states.drain():
                if rx.msg.phase != phase or rx.msg.episode_id != episode_id:
                    phase, episode_id = rx.msg.phase, rx.msg.episode_id
                    if phase == "reach":
                        reach_since = rx.rx_monotonic
                        wait_after_reach_s = rng.uniform(0.1, 0.6)
                    if pending is not None and phase == "released" and pending["released"] is None:
                        pending["released"] = rx.rx_monotonic
                        pending["released_ns"] = rx.msg.stamp_ns
                    if phase in ("done", "failed", "protective_stop"):
                        done_episodes.add(episode_id)
                    if phase == "protective_stop":
                        protective_stops.append(rx.msg.reason)
            if protective_stops:
                break  # the supervisor never moves again after a protective stop
            for rx in stops.drain():
                if rx.msg.protective and rx.msg.source == "launcher":  # its watch of a silent supervisor
                    protective_stops.append(rx.msg.reason)
                if pending is not None and pending["stop"] is None and rx.msg.reason == "release":
                    pending["stop"] = rx.rx_monotonic
                    pending["stop_ns"] = rx.msg.stamp_ns
            for rx in joints.drain():
                speed = max((abs(v) for v in rx.msg.velocity_rad_s), default=0.0)
                if pending is not None and pending["rest"] is None and rx.rx_monotonic >= pending["t0"] \
                        and speed < REST_SPEED_RAD_S:
                    pending["rest"] = rx.rx_monotonic
                if pending is not None and pending["rest_ns"] is None and rx.msg.stamp_ns >= pending["t0_ns"] \
                        and speed < REST_SPEED_RAD_S:
                    pending["rest_ns"] = rx.msg.stamp_ns
                if (pending is None or pending["episode"] != episode_id) and phase == "reach" \
                        and reach_since is not None and rx.rx_monotonic - reach_since >= wait_after_reach_s \
                        and speed >= MOVING_RAD_S and episode_id not in {s.episode_id for s in samples}:
                    if pending is not None:
                        samples.append(_sample(pending))
                    pending = {"episode": episode_id, "speed": speed, "stop": None, "released": None,
                               "rest": None, "t0": time.monotonic(), "stop_ns": None, "released_ns": None,
                               "rest_ns": None, "t0_ns": time.time_ns()}
                    release_pub.put(grip_force_n=0.0, pull_force_n=0.0, controller="release-bench")
            if pending is not None and pending["rest"] is not None and pending["stop"] is not None \
                    and pending["released"] is not None:
                samples.append(_sample(pending))
                pending = None
        if pending is not None and not protective_stops:  # one cut short by a protective stop is no sample
            samples.append(_sample(pending))
        if protective_stops_out is not None:
            protective_stops_out.extend(protective_stops)
    finally:
        if node is not None:
            node.close()
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(30.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(5.0)
        reader.join(5.0)
        for line in lines:
            if line.startswith("[launcher] started "):
                parts = line.split()
                name, pid = parts[2], int(parts[4].rstrip("):"))
                p = _owned(pid, name)
                if p is not None:
                    p.kill()
        for path in workdir.glob(f"handover-release-bench-{port}*.rrd"):
            path.unlink(missing_ok=True)
        shutil.rmtree(workdir / f"handover-release-bench-{port}-logs", ignore_errors=True)
    return samples


def _sample(p: dict) -> ReleaseSample:
    def since(key: str) -> float | None:
        return None if p[key] is None else p[key] - p["t0"]

    def since_ns(key: str) -> float | None:
        return None if p[key] is None else (p[key] - p["t0_ns"]) / 1e9

    return ReleaseSample(p["episode"], p["speed"], since("stop"), since("released"), since("rest"),
                         since_ns("stop_ns"), since_ns("released_ns"), since_ns("rest_ns"))
