"""The writer on a synthetic stream at the stack's real rates, read back from the real .rrd:
size per second, depth only when asked, unknown keys with bounded state, stamp-ordered review."""

from __future__ import annotations

import logging
import time

import msgspec
import numpy as np
import pytest

from bus_schema import encode_for, topic_for_key, topics
from services.recorder.config import RecorderConfig
from services.recorder.readback import entity_row_counts, read_component, read_scalars
from services.recorder.writer import RecordingWriter
from tests.samples import SAMPLES
from tests.unit.recorder.stream import IDLE_RATES_HZ, PREFIX, idle_stream

#: issue 16: a default run's recording ≤ 0.5 MB per second of run.
MAX_BYTES_PER_S = 0.5e6
RUN_S = 12.0


def _replay(writer: RecordingWriter, stream, flush_period_s: float) -> None:
    """Hand `stream` to `writer`, writing once per `flush_period_s` of stream time, then close."""
    next_flush = flush_period_s
    for offset_s, key, payload in stream:
        if offset_s >= next_flush:
            writer.pump(force=True)
            next_flush += flush_period_s
        writer.handle(key, payload, time.time_ns())
    writer.close()


def _default_stream(seconds: float):
    """What the default recorder receives: every key at its idle rate but depth (not subscribed)."""
    rates = {k: v for k, v in IDLE_RATES_HZ.items() if k != topics.DEPTH.suffix}
    return idle_stream(seconds, rates)


def test_default_recording_of_a_run_is_under_half_a_megabyte_per_second(tmp_path):
    """12 s at the idle stack's rates (robot model, start-up and blueprint included)."""
    out = tmp_path / "run.rrd"
    stream = _default_stream(RUN_S)
    writer = RecordingWriter(out, PREFIX)
    _replay(writer, stream, writer.config.flush_period_s)
    bytes_per_s = out.stat().st_size / RUN_S
    assert bytes_per_s < MAX_BYTES_PER_S, f"{bytes_per_s / 1e6:.3f} MB/s"
    # Small because it is compact, not because something is missing: every message is there.
    counts = entity_row_counts(out, include_static=False)
    sent: dict[str, int] = {}
    for _, key, _ in stream:
        suffix = topic_for_key(key, PREFIX).suffix  # every sender's heartbeat key: one entity
        sent[suffix] = sent.get(suffix, 0) + 1
    for suffix, n in sent.items():
        assert counts[f"/bus/{suffix}"] == n, suffix
    assert counts["/robot/joint_position"] == sent[topics.JOINT_STATE.suffix]
    wrench = [msgspec.msgpack.decode(p, type=topics.WRIST_WRENCH.type) for _, k, p in stream
              if k == topics.WRIST_WRENCH.key(PREFIX)]
    times, values = read_scalars(out, "/bus/sensors/wrist_wrench/force_n/1")["/bus/sensors/wrist_wrench/force_n/1"]
    assert times.tolist() == [w.stamp_ns for w in wrench]
    assert values.tolist() == [w.force_n[1] for w in wrench]
    assert writer.stats.rejected == 0 and writer.stats.ignored == 0


def _depth_stream(seconds: float):
    return idle_stream(seconds, {topics.DEPTH.suffix: 30.0, topics.WRIST_WRENCH.suffix: 100.0})


def test_depth_is_not_recorded_by_default(tmp_path):
    out = tmp_path / "nodepth.rrd"
    writer = RecordingWriter(out, PREFIX, RecorderConfig(robot_model="none"))
    _replay(writer, _depth_stream(1.0), 1.0)
    counts = entity_row_counts(out)
    assert not any("depth" in entity for entity in counts), counts
    assert writer.stats.ignored == 30  # handed over by key: counted, not written
    assert counts["/bus/sensors/wrist_wrench"] == 100


@pytest.mark.parametrize("every, images", [(1, 30), (3, 10)])
def test_depth_option_records_every_frame_and_one_image_in_n(tmp_path, every, images):
    out = tmp_path / f"depth{every}.rrd"
    writer = RecordingWriter(out, PREFIX, RecorderConfig(robot_model="none", depth_every=every))
    _replay(writer, _depth_stream(1.0), 0.5)
    counts = entity_row_counts(out, include_static=False)
    assert counts["/bus/perception/depth"] == 30  # the numbers of every frame
    assert counts["/camera/depth"] == images
    widths = read_scalars(out, "/bus/perception/depth/width")["/bus/perception/depth/width"][1]
    assert set(widths.tolist()) == {320.0}


def test_unknown_keys_keep_bounded_state_and_log_one_line(tmp_path, caplog):
    writer = RecordingWriter(tmp_path / "unknown.rrd", PREFIX, RecorderConfig(robot_model="none"))
    payload = encode_for(topics.WRIST_WRENCH, SAMPLES["sensors/wrist_wrench"])
    with caplog.at_level(logging.WARNING, logger="services.recorder.writer"):
        for i in range(3000):
            writer.handle(f"{PREFIX}/stranger/{i}", payload, i)
    unknown = writer.stats.unknown
    assert unknown.count == 3000
    assert len(unknown.seen) == unknown.max_kept == 16
    lines = [r for r in caplog.records if "no message type" in r.getMessage()]
    assert len(lines) == 1
    assert len(unknown._log.counts) == 1  # one rate-limit key for all unknown keys
    writer.handle(topics.WRIST_WRENCH.key(PREFIX), payload, 1)
    writer.close()
    assert entity_row_counts(tmp_path / "unknown.rrd", include_static=False) == {"/bus/sensors/wrist_wrench": 1}


def test_release_marker_uses_the_tool_position_at_the_release_stamp(tmp_path):
    """Keys are written batch by batch; the review state still sees messages in stamp order."""
    out = tmp_path / "order.rrd"
    writer = RecordingWriter(out, PREFIX, RecorderConfig(robot_model="none"))
    truth, release = SAMPLES["sim/truth"], SAMPLES["gripper/release"]
    for i, x_m in enumerate((0.5, 0.6, 0.7, 0.8)):  # the release comes between 0.6 and 0.7
        msg = msgspec.structs.replace(truth, seq=i, stamp_ns=1_000 + 10 * i, tool_position_m=(x_m, 0.0, 0.1))
        writer.add(topics.SIM_TRUTH, encode_for(topics.SIM_TRUTH, msg), 2_000 + i)
    writer.add(topics.GRIPPER_RELEASE, encode_for(topics.GRIPPER_RELEASE,
                                                  msgspec.structs.replace(release, stamp_ns=1_015)), 2_010)
    writer.close()  # one flush holds all of them
    marker = read_component(out, "world/release", "Points3D:positions")
    assert marker[0][0] == 1_015
    np.testing.assert_allclose(marker[0][1], [[0.6, 0.0, 0.1]], atol=1e-6)


def test_file_is_readable_before_close_up_to_the_last_flush(tmp_path):
    """What SIGKILL leaves: the file as of the last flush, no footer, no close."""
    out = tmp_path / "open.rrd"
    writer = RecordingWriter(out, PREFIX, RecorderConfig(robot_model="none"))
    payload = encode_for(topics.WRIST_WRENCH, SAMPLES["sensors/wrist_wrench"])
    for i in range(50):
        writer.add(topics.WRIST_WRENCH, payload, i)
    writer.pump(force=True)
    for i in range(7):
        writer.add(topics.WRIST_WRENCH, payload, 100 + i)  # after the flush: not in the file yet
    assert entity_row_counts(out, include_static=False) == {"/bus/sensors/wrist_wrench": 50}
    writer.close()
    assert entity_row_counts(out, include_static=False) == {"/bus/sensors/wrist_wrench": 57}
