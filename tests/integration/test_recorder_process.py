"""The recorder as a real process: the file stays valid when the recorder is killed."""

from __future__ import annotations

import shutil
import signal
import subprocess
import time

import numpy as np
import pytest

from bus_schema import topics
from services.recorder.readback import entity_row_counts, read_scalars
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
        time.sleep(0.6)  # several 100 ms flush periods
        rec.proc.send_signal(signal.SIGKILL)
        rec.proc.wait(10)
    values = read_scalars(out, "/bus/sensors/wrist_wrench/force_n/0")["/bus/sensors/wrist_wrench/force_n/0"][1]
    # Everything flushed before the kill is there and intact.
    assert np.array_equal(values, np.arange(len(values), dtype=float))
    assert len(values) == 150
