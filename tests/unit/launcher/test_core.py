"""Launcher's pure logic: orders, restart policy, commands."""

from __future__ import annotations

import signal
import sys
from pathlib import Path

from services.launcher.core import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    bus_port_message,
    decide_restart,
    describe_exit,
    final_exit_code,
    job_services,
    prefix_line,
    recording_path,
    scene_service,
    service_command,
    shutdown_order,
    start_order,
)
from services.runtime.profile import ServiceSpec, load_profile_file

SPECS = [ServiceSpec("bridge", "services.bridge", safety=True), ServiceSpec("motion", "services.motion"),
         ServiceSpec("recorder", "services.recorder", restart="on-failure", max_restarts=2),
         ServiceSpec("off", "services.off", enabled=False)]


def test_recorder_starts_first_and_stops_last():
    assert [s.name for s in start_order(SPECS)] == ["recorder", "bridge", "motion"]
    assert [s.name for s in shutdown_order(SPECS)] == ["motion", "bridge", "recorder"]


def test_safety_service_never_restarts_mid_episode():
    spec = ServiceSpec("gripper", "services.gripper", safety=True, restart="on-failure", max_restarts=5)
    assert not decide_restart(spec, 0, episode_running=True, exit_code=-9).restart
    assert "safety service" in decide_restart(spec, 0, True, -9).reason
    assert decide_restart(spec, 0, episode_running=False, exit_code=1).restart


def test_restart_budget():
    rec = SPECS[2]
    assert decide_restart(rec, 0, True, 1).restart
    assert decide_restart(rec, 1, True, 1).restart
    last = decide_restart(rec, 2, True, 1)
    assert not last.restart and "max_restarts = 2" in last.reason
    assert not decide_restart(SPECS[1], 0, False, 1).restart


def test_describe_exit():
    assert describe_exit(-signal.SIGKILL) == "was killed by SIGKILL"
    assert describe_exit(3) == "exited with code 3"
    assert describe_exit(None) == "is still running"


def test_service_command_carries_profile_and_bus():
    profile = load_profile_file("sim").with_bus("tcp/127.0.0.1:9123")
    cmd = service_command(SPECS[0], profile, ["--x"])
    assert cmd[:3] == [sys.executable, "-m", "services.bridge"]
    assert cmd[cmd.index("--endpoint") + 1] == "tcp/127.0.0.1:9123"
    assert cmd[-1] == "--x"


def test_recording_paths_and_prefix():
    assert recording_path(Path("r"), "run1") == Path("r/handover-run1.rrd")
    assert recording_path(Path("r"), "run1", 1) == Path("r/handover-run1-part2.rrd")
    assert prefix_line("bridge", "hello\n", 8) == "[bridge]   hello\n"


def test_the_demo_job_runs_no_supervisor_and_the_others_every_enabled_service_in_start_order():
    specs = [*SPECS, ServiceSpec("supervisor", "services.supervisor")]
    assert [s.name for s in job_services(specs, "demo")] == ["recorder", "bridge", "motion"]
    for job in ("handover", "check", "none"):
        assert [s.name for s in job_services(specs, job)] == ["recorder", "bridge", "motion", "supervisor"]


def test_the_scene_is_the_fake_baxters_when_there_is_one_else_the_bridges():
    assert scene_service(SPECS) == "bridge"
    assert scene_service([*SPECS, ServiceSpec("fake_baxter", "services.fake_baxter")]) == "fake_baxter"


def test_a_job_that_succeeded_exits_failed_after_a_failure_and_interrupted_after_a_stop():
    assert final_exit_code(EXIT_OK, None, False) == EXIT_OK
    assert final_exit_code(EXIT_OK, "bridge exited with code 1", False) == EXIT_FAILED
    assert final_exit_code(EXIT_OK, None, True) == EXIT_INTERRUPTED
    assert final_exit_code(EXIT_OK, "bridge exited with code 1", True) == EXIT_FAILED  # the failure first
    # A job that did not succeed keeps its own code.
    assert final_exit_code(EXIT_FAILED, None, True) == EXIT_FAILED
    assert final_exit_code(EXIT_INTERRUPTED, "bridge exited with code 1", True) == EXIT_INTERRUPTED


def test_the_bus_port_message_drops_zenohs_source_locations():
    text = ("Can not create a new TCP listener bound to tcp/127.0.0.1:7447: Address already in use "
            "(os error 98) at /home/runner/.cargo/registry/src/zenoh-link-tcp-1.0.0/src/unicast.rs:335.")
    assert bus_port_message("tcp/127.0.0.1:7447", text) == (
        "cannot host the bus on tcp/127.0.0.1:7447 (is another handover-up running? use --port auto): "
        "Can not create a new TCP listener bound to tcp/127.0.0.1:7447: Address already in use (os error 98)")
