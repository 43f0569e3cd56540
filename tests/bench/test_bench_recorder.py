"""Recorder cost at the idle stack's bus rates: CPU, flush times and recording size, before vs after.

The stream (`tests.unit.recorder.stream.idle_stream`): every key at the rates measured on an
idle `handover-up` (≈ 1 050 messages/s: heartbeats 156/s; joint state, joint command, wrist
wrench, object motion, sim truth 100/s; gripper command 130/s, state 70/s; skeleton, depth,
Kinect truth, human 30/s; motion status 50/s; supervisor 10/s; transfer 5/s), real bus messages
with every float varying, depth 320 × 240 (150 kB each, 4.6 MB/s).

Two recorders, measured in the same run on the same stream:
- before: the recorder of commit `BASELINE_REV` (its code extracted with `git archive`; its own
  defaults: subscribes to ``<prefix>/**`` so depth reaches it, one depth image in 3, Baxter's
  meshes, a write and flush every 0.1 s);
- after: this recorder with its defaults (depth not subscribed, primitive robot model, a write
  and flush every 1 s).

`test_recorder_process_cpu_before_after`: each recorder runs as its own process on a loopback
bus; this process publishes the stream at its real times for `STREAM_S` s (depth included: the
stack's Kinect publishes it whether anyone records it or not) and samples the recorder's CPU
time (psutil, user + system, all its threads) and RSS once a second. Reported: cores (CPU s per
s) per 1 s sample, median and p99; the recording's size per second of the recorder's run (start
to exit); the flush times from its closing line (after only); RSS after start-up and its
largest sample (DESIGN §9: ≤ 300 MB).

`test_recorder_writer_replay_before_after`: the writer alone, in a fresh interpreter per
variant, fed the same stream as fast as it can (no bus), a write every flush period of stream
time: CPU s per s of stream (time.process_time, all threads), messages per wall second, each
write-and-flush's duration (median, p99) and bytes per second of stream.

Run: python -m pytest tests/bench/test_bench_recorder.py -m bench -s
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import psutil
import pytest

from services.runtime.testing import wait_alive, wait_until
from tests.bench._report import save, table
from tests.unit.recorder.stream import IDLE_RATES_HZ, idle_stream

pytestmark = pytest.mark.bench

ROOT = Path(__file__).resolve().parents[2]
#: The last commit with the previous recorder (override: RECORDER_BASELINE_REV).
BASELINE_REV = os.environ.get("RECORDER_BASELINE_REV", "bddf4e6")
STREAM_S = 15.0
REPLAY_S = 20.0

#: Runs the recorder CLI with `services.recorder` taken from argv[1] (the baseline's code).
_BASELINE_MAIN = r"""
import sys
import services
services.__path__.insert(0, sys.argv[1])
from services.recorder.cli import main
raise SystemExit(main(sys.argv[2:]))
"""


@pytest.fixture(scope="module")
def baseline_dir(tmp_path_factory) -> Path:
    """The baseline recorder's code (`git archive BASELINE_REV services/recorder`)."""
    out = tmp_path_factory.mktemp("baseline")
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", BASELINE_REV, "services/recorder"],
                             capture_output=True, check=False)
    if archive.returncode != 0:
        pytest.skip(f"baseline {BASELINE_REV} not available: {archive.stderr.decode()[:200]}")
    subprocess.run(["tar", "-x", "-C", str(out)], input=archive.stdout, check=True)
    return out / "services"


def _baseline_profile(tmp: Path) -> Path:
    """deploy/sim.toml with the recorder table the baseline reads (its own defaults)."""
    text = (ROOT / "deploy" / "sim.toml").read_text()
    text = re.sub(r"\[services\.recorder\.config\]\n(?:[^\n\[]*\n)*?\n",
                  "[services.recorder.config]\nurdf = true\ndepth_every = 3\n\n", text, count=1)
    path = tmp / "baseline_sim.toml"
    path.write_text(text)
    return path


def _publish(session, prefix: str, stream) -> None:
    pubs = {key: session.declare_publisher(key) for key in {key for _, key, _ in stream}}
    t0 = time.monotonic()
    for offset_s, key, payload in stream:
        delay = t0 + offset_s - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        pubs[key].put(payload)
    for pub in pubs.values():
        pub.undeclare()


def _run_process(variant: str, cmd: list[str], profile, router, make_node, out: Path, stream) -> dict:
    log_path = out.with_suffix(".log")
    with open(log_path, "w") as log_file:
        t_start = time.monotonic()
        proc = subprocess.Popen(cmd, stdout=log_file, stderr=subprocess.STDOUT,
                                env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        wait_alive(router, profile, {"recorder"}, timeout_s=30.0)
        assert wait_until(lambda: "recording output=" in log_path.read_text(), 60.0), log_path.read_text()
        node = make_node(f"bench-{variant}")
        time.sleep(1.0)  # start-up work done
        ps = psutil.Process(proc.pid)
        samples: list[float] = []
        done = threading.Event()

        rss: list[int] = [ps.memory_info().rss]

        def sample() -> None:
            last_t, last_cpu = time.monotonic(), sum(ps.cpu_times()[:2])
            while not done.wait(1.0):
                t, cpu = time.monotonic(), sum(ps.cpu_times()[:2])
                samples.append((cpu - last_cpu) / (t - last_t))
                rss.append(ps.memory_info().rss)
                last_t, last_cpu = t, cpu

        sampler = threading.Thread(target=sample)
        sampler.start()
        _publish(node.session, profile.prefix, stream)
        done.set()
        sampler.join()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(60) == 0, log_path.read_text()[-3000:]
        run_s = time.monotonic() - t_start
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    text = log_path.read_text()
    flush = re.search(r"flush_ms_median=([\d.]+) flush_ms_p99=([\d.]+)", text)
    cores = np.asarray(samples[1:])  # the first second includes the stream's start
    return {"cores_median": float(np.median(cores)), "cores_p99": float(np.percentile(cores, 99)),
            "cores_mean": float(cores.mean()), "samples": len(cores), "file_mb": out.stat().st_size / 1e6,
            "run_s": run_s, "mb_per_s_of_run": out.stat().st_size / 1e6 / run_s,
            "rss_after_start_mb": rss[0] / 1e6, "rss_max_mb": max(rss) / 1e6,
            "flush_ms_median": float(flush[1]) if flush else None, "flush_ms_p99": float(flush[2]) if flush else None}


def test_recorder_process_cpu_before_after(bus, make_node, tmp_path, baseline_dir):
    profile, router = bus
    stream = idle_stream(STREAM_S, t0_ns=time.time_ns())
    base_args = ["--endpoint", profile.endpoint, "--prefix", profile.prefix]
    variants = {
        "before": [sys.executable, "-c", _BASELINE_MAIN, str(baseline_dir), "--profile",
                   str(_baseline_profile(tmp_path)), *base_args, "--output", str(tmp_path / "before.rrd")],
        "after": [sys.executable, "-m", "services.recorder", "--profile", "sim", *base_args,
                  "--output", str(tmp_path / "after.rrd")],
    }
    results = {name: _run_process(name, cmd, profile, router, make_node, tmp_path / f"{name}.rrd", stream)
               for name, cmd in variants.items()}
    before, after = results["before"], results["after"]
    results["ratio_cores_median_after_over_before"] = after["cores_median"] / before["cores_median"]
    results["ratio_mb_per_s_after_over_before"] = after["mb_per_s_of_run"] / before["mb_per_s_of_run"]
    rows = [(name, f"{r['cores_median']:.3f}", f"{r['cores_p99']:.3f}", f"{r['file_mb']:.1f}", f"{r['run_s']:.1f}",
             f"{r['mb_per_s_of_run']:.3f}", "–" if r["flush_ms_median"] is None else f"{r['flush_ms_median']:.1f}",
             "–" if r["flush_ms_p99"] is None else f"{r['flush_ms_p99']:.1f}", f"{r['rss_after_start_mb']:.0f}",
             f"{r['rss_max_mb']:.0f}")
            for name, r in results.items() if isinstance(r, dict)]
    print(f"\nrecorder process at the idle bus rates ({sum(IDLE_RATES_HZ.values()):.0f} msg/s, {STREAM_S:.0f} s)")
    print(table(rows, ("recorder", "cores median", "cores p99", "file MB", "run s", "MB per s of run",
                       "flush ms median", "flush ms p99", "RSS after start MB", "RSS max MB")))
    print(f"after/before: cores {results['ratio_cores_median_after_over_before']:.2f}x, "
          f"MB/s {results['ratio_mb_per_s_after_over_before']:.3f}x")
    save("recorder_process", results)
    assert after["mb_per_s_of_run"] < 0.5
    assert after["cores_median"] < before["cores_median"]
    assert after["rss_max_mb"] < 300  # DESIGN §9


#: Runs one writer on the stream in a fresh interpreter: argv = variant, baseline dir, output, seconds.
_REPLAY = r"""
import json, sys, time
variant, base, out, seconds = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
import services
if variant == "before":
    services.__path__.insert(0, base)
from pathlib import Path
from tests.unit.recorder.stream import IDLE_RATES_HZ, idle_stream
rates = dict(IDLE_RATES_HZ)
if variant == "after":  # not subscribed
    rates.pop("perception/depth")
stream = idle_stream(seconds, rates)
from services.recorder.writer import RecordingWriter
if variant == "before":
    writer, period = RecordingWriter(Path(out), "handover/v1"), 0.1
else:
    from services.recorder.config import RecorderConfig
    config = RecorderConfig(depth_every=1) if variant == "after, depth_every = 1" else RecorderConfig()
    writer, period = RecordingWriter(Path(out), "handover/v1", config), config.flush_period_s
flush_s, next_flush = [], period
c0, t0 = time.process_time(), time.perf_counter()
for offset, key, payload in stream:
    if offset >= next_flush:
        t = time.perf_counter(); writer.pump(force=True); flush_s.append(time.perf_counter() - t)
        next_flush += period
    writer.handle(key, payload, time.time_ns())
if variant == "before":
    writer.close()
else:  # the writer's cost only: finalising (a child process compacting the file) is measured in docs/recorder.md
    writer.close(finalise=False)
cpu, wall = time.process_time() - c0, time.perf_counter() - t0
print(json.dumps({"cpu_s_per_s": cpu / seconds, "flush_s": flush_s, "bytes": Path(out).stat().st_size,
                  "messages": sum(writer.stats.logged.values()), "sustained_msgs_per_s": len(stream) / wall}))
"""


def test_recorder_writer_replay_before_after(tmp_path, baseline_dir):
    results = {}
    for variant in ("before", "after", "after, depth_every = 1"):
        out = tmp_path / f"{variant.replace(' ', '').replace(',', '_').replace('=', '')}.rrd"
        done = subprocess.run([sys.executable, "-c", _REPLAY, variant, str(baseline_dir), str(out), str(REPLAY_S)],
                              capture_output=True, text=True, timeout=900, cwd=ROOT,
                              env={**os.environ, "PYTHONPATH": str(ROOT)}, check=False)
        assert done.returncode == 0, done.stderr[-3000:]
        r = json.loads(done.stdout.strip().splitlines()[-1])
        flush_ms = 1e3 * np.asarray(r.pop("flush_s"))
        results[variant] = {**r, "flush_ms_median": float(np.median(flush_ms)),
                            "flush_ms_p99": float(np.percentile(flush_ms, 99)), "flushes": int(flush_ms.size),
                            "mb_per_s": r["bytes"] / 1e6 / REPLAY_S}
    rows = [(v, f"{r['messages']}", f"{r['cpu_s_per_s']:.3f}", f"{r['sustained_msgs_per_s']:.0f}", f"{r['flushes']}",
             f"{r['flush_ms_median']:.1f}", f"{r['flush_ms_p99']:.1f}", f"{r['mb_per_s']:.3f}")
            for v, r in results.items()]
    before, after = results["before"], results["after"]
    results["ratio_cpu_after_over_before"] = after["cpu_s_per_s"] / before["cpu_s_per_s"]
    print(f"\nrecorder writer replay, {REPLAY_S:.0f} s of the idle stream as fast as possible")
    print(table(rows, ("writer", "messages", "CPU s per s of stream", "sustained msg/s", "flushes", "flush ms median",
                       "flush ms p99", "MB per s of stream")))
    print(f"after/before CPU: {results['ratio_cpu_after_over_before']:.2f}x")
    save("recorder_replay", results)
    assert after["mb_per_s"] < 0.5 and after["cpu_s_per_s"] < before["cpu_s_per_s"]
    assert after["sustained_msgs_per_s"] > 10 * sum(IDLE_RATES_HZ.values())  # far above what the bus offers
