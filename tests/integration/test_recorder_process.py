"""The recorder as a real process: a file closed by SIGINT/SIGTERM passes `rerun rrd verify`; one
killed with SIGKILL is readable, and `handover-recorder finalise` makes it verify with everything
flushed before the kill; depth images reach it only when asked."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from bus_schema import TOPICS, topics
from services.recorder.config import parse_config
from services.recorder.finalise import rerun_cli
from services.recorder.readback import entity_row_counts, read_scalars, read_times
from services.runtime.testing import ServiceProcess, wait_alive, wait_until

pytestmark = pytest.mark.integration


def _publish_forces(node, n, period_s=0.005):
    pub = node.publisher(topics.WRIST_WRENCH)
    time.sleep(0.2)
    for i in range(n):
        pub.put(force_n=(float(i), 0.0, 0.0))
        time.sleep(period_s)


def _rerun_verify(path) -> subprocess.CompletedProcess:
    """Rerun's own check of the file as it is (it needs the footer the recorder adds at close)."""
    return subprocess.run([rerun_cli(), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)


def _finalise(*paths) -> subprocess.CompletedProcess:
    """`handover-recorder finalise PATH…` as a real process."""
    return subprocess.run([sys.executable, "-m", "services.recorder", "finalise", *map(str, paths)],
                          capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_recording_complete_after_sigterm(bus, make_node, tmp_path, sig):
    profile, router = bus
    out = tmp_path / "run.rrd"
    with ServiceProcess("services.recorder", profile, ["--output", str(out)]) as rec:
        wait_alive(router, profile, {"recorder"})
        _publish_forces(make_node(), 200)
        time.sleep(0.3)
        rec.proc.send_signal(sig)
        assert rec.proc.wait(10) == 0, rec.log_text()
    values = read_scalars(out, "/bus/sensors/wrist_wrench/force_n/0")["/bus/sensors/wrist_wrench/force_n/0"][1]
    assert values.tolist() == [float(i) for i in range(200)]  # every message, in order
    # receive_time: when the router got each message (its timestamp), not when the recorder
    # took it from its queue once a second: within milliseconds of the sender's stamp.
    stamps, receives = read_times(out, "/bus/sensors/wrist_wrench")
    latency_s = (receives - stamps) / 1e9
    assert len(latency_s) == 200 and latency_s.min() >= 0.0 and np.median(latency_s) < 0.05, latency_s
    assert any(e.startswith("/transforms") or "baxter" in e for e in entity_row_counts(out))
    verify = _rerun_verify(out)
    assert verify.returncode == 0, verify.stdout + verify.stderr  # finalised at close: the footer is there
    assert "finalised=True" in rec.log_text(), rec.log_text()


def test_recording_after_sigkill_is_readable_and_finalise_makes_it_verify(bus, make_node, tmp_path):
    profile, router = bus
    out = tmp_path / "killed.rrd"
    with ServiceProcess("services.recorder", profile, ["--output", str(out), "--no-urdf"]) as rec:
        wait_alive(router, profile, {"recorder"})
        # The token goes up before Rerun is imported and the file opened (0.8-3 s on a loaded
        # machine): until then messages only queue, and a kill would lose them all.
        assert wait_until(lambda: "recording output=" in rec.log_text(), 30.0), rec.log_text()
        _publish_forces(make_node(), 150)
        time.sleep(2 * parse_config(profile.service_config("recorder")).flush_period_s + 0.5)  # ≥ one flush
        rec.proc.send_signal(signal.SIGKILL)
        rec.proc.wait(10)
    values = read_scalars(out, "/bus/sensors/wrist_wrench/force_n/0")["/bus/sensors/wrist_wrench/force_n/0"][1]
    # Everything flushed before the kill is there and intact.
    assert np.array_equal(values, np.arange(len(values), dtype=float))
    assert len(values) == 150
    rows_before = entity_row_counts(out, include_static=False)
    verify = _rerun_verify(out)
    assert verify.returncode == 1 and "footer" in verify.stdout + verify.stderr  # killed: no footer

    done = _finalise(out)

    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.startswith(f"finalised {out}: kept ") and done.stdout.count("\n") == 1, done.stdout
    heartbeats = rows_before.get("/bus/runtime/heartbeat", 0)
    assert f"kept {150 + heartbeats} bus messages" in done.stdout, (done.stdout, rows_before)
    verify = _rerun_verify(out)
    assert verify.returncode == 0, verify.stdout + verify.stderr
    values = read_scalars(out, "/bus/sensors/wrist_wrench/force_n/0")["/bus/sensors/wrist_wrench/force_n/0"][1]
    assert values.tolist() == [float(i) for i in range(150)]
    assert entity_row_counts(out, include_static=False) == rows_before  # nothing lost, nothing added


def test_finalise_refuses_a_file_that_is_not_a_recording(tmp_path):
    notes = tmp_path / "notes.rrd"
    notes.write_text("not a recording\n")
    done = _finalise(notes)
    assert done.returncode == 1, done.stdout + done.stderr
    lines = (done.stdout + done.stderr).strip().splitlines()
    assert len(lines) == 1 and "is not a Rerun recording" in lines[0] and "left unchanged" in lines[0], lines
    assert notes.read_text() == "not a recording\n"
    assert [p.name for p in tmp_path.iterdir()] == ["notes.rrd"]
    # Usage errors: exit 2, before any file is touched.
    assert _finalise(tmp_path / "missing.rrd").returncode == 2
    assert _finalise().returncode == 2
    assert _finalise(notes, tmp_path / "missing.rrd").returncode == 2


def _publish_depth(node, n):
    pub = node.publisher(topics.DEPTH)
    time.sleep(0.3)
    for i in range(n):
        pub.put(width=4, height=3, depth_mm=bytes(24), fx=285.0, fy=285.0, cx=2.0, cy=1.5)
        time.sleep(0.02)


@pytest.mark.parametrize("args, images", [([], 0), (["--depth-every", "1"], 20)])
def test_depth_reaches_the_recorder_only_when_asked(bus, make_node, tmp_path, args, images):
    profile, router = bus
    out = tmp_path / "depth.rrd"
    with ServiceProcess("services.recorder", profile, ["--output", str(out), "--no-urdf", *args]) as rec:
        wait_alive(router, profile, {"recorder"})
        assert wait_until(lambda: "recording output=" in rec.log_text(), 30.0), rec.log_text()
        node = make_node()
        _publish_depth(node, 20)
        _publish_forces(node, 10)
        time.sleep(0.3)
        rec.proc.send_signal(signal.SIGTERM)
        assert rec.proc.wait(30) == 0, rec.log_text()
        log_text = rec.log_text()
    counts = entity_row_counts(out, include_static=False)
    assert counts.get("/bus/perception/depth", 0) == images  # default: not even subscribed
    assert counts.get("/camera/depth", 0) == images
    assert counts["/bus/sensors/wrist_wrench"] == 10
    recorded = len(TOPICS) - 2  # never the simulation clock's two keys
    subscribed = recorded if images else recorded - 1
    assert f"keys={subscribed}" in log_text and "rejected=0" in log_text
