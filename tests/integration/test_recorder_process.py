"""The recorder as a real process: the file stays valid when the recorder is killed; depth images
reach it only when asked."""

from __future__ import annotations

import shutil
import signal
import subprocess
import time

import numpy as np
import pytest

from bus_schema import TOPICS, topics
from services.recorder.config import parse_config
from services.recorder.readback import entity_row_counts, read_scalars, read_times
from services.runtime.testing import ServiceProcess, wait_alive, wait_until

pytestmark = pytest.mark.integration


def _publish_forces(node, n, period_s=0.005):
    pub = node.publisher(topics.WRIST_WRENCH)
    time.sleep(0.2)
    for i in range(n):
        pub.put(force_n=(float(i), 0.0, 0.0))
        time.sleep(period_s)


def _rerun_verify(path):
    """Rerun's own check. The recorder writes no footer (memory, see services/recorder/writer.py),
    which `rrd verify` requires: `rrd optimize` first decodes every chunk of the file and writes
    a copy with a footer, then `rrd verify` checks that copy."""
    import sys
    from pathlib import Path

    beside = Path(sys.executable).with_name("rerun")
    exe = str(beside) if beside.exists() else shutil.which("rerun")
    if exe is None:
        pytest.skip("rerun CLI not on PATH")
    copy = Path(path).with_suffix(".optimized.rrd")
    optimized = subprocess.run([exe, "rrd", "optimize", str(path), "-o", str(copy)], capture_output=True, text=True,
                               timeout=120)
    if optimized.returncode != 0:
        return optimized
    return subprocess.run([exe, "rrd", "verify", str(copy)], capture_output=True, text=True, timeout=120)


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
    assert _rerun_verify(out).returncode == 0


def test_recording_readable_after_sigkill(bus, make_node, tmp_path):
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
    subscribed = len(TOPICS) if images else len(TOPICS) - 1
    assert f"keys={subscribed}" in log_text and "rejected=0" in log_text
