"""Finalising recordings (services/recorder/finalise.py) on real files written by the real writer,
checked with Rerun's own `rerun rrd verify`: a file closed normally verifies; a file cut off in the
middle of a message (what a SIGKILL during a write leaves) is repaired with every complete message
and says what it dropped; anything else is refused and left byte for byte as it was."""

from __future__ import annotations

import subprocess

import msgspec
import numpy as np
import pytest

from bus_schema import encode_for, topics
from services.recorder.config import RecorderConfig
from services.recorder.errors import RecorderError
from services.recorder.finalise import RecordingUnreadable, finalise, has_footer, read_contents, rerun_cli
from services.recorder.readback import entity_row_counts, read_scalars
from services.recorder.writer import RecordingWriter
from tests.samples import SAMPLES
from tests.unit.recorder.stream import PREFIX

WRENCH = "/bus/sensors/wrist_wrench"


def _verify(path) -> subprocess.CompletedProcess:
    return subprocess.run([rerun_cli(), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)


def _wrench(i: int) -> bytes:
    """Wrist wrench number `i`: force x = i, stamped (i + 1) ms."""
    message = msgspec.structs.replace(SAMPLES["sensors/wrist_wrench"], seq=i, stamp_ns=1_000_000 * (i + 1),
                                      force_n=(float(i), 0.0, 0.0))
    return encode_for(topics.WRIST_WRENCH, message)


def test_a_closed_recording_verifies_and_keeps_every_row(tmp_path):
    out = tmp_path / "closed.rrd"
    writer = RecordingWriter(out, PREFIX)  # with Baxter's model and the blueprint: every store
    for i in range(300):
        writer.add(topics.WRIST_WRENCH, _wrench(i), 1_000_000 * (i + 1))
        if i % 100 == 99:
            writer.pump(force=True)  # three flushes: three chunks of the key, merged by finalise
    writer.close(finalise=False)
    assert _verify(out).returncode == 1 and not has_footer(out)  # what the recorder streams
    before = read_contents(out)

    report = finalise(out)

    assert has_footer(out)
    verify = _verify(out)
    assert verify.returncode == 0, verify.stderr
    assert report.kept.rows == before.rows and report.kept.static == before.static  # every store, every entity
    assert report.kept.bus_messages() == {"sensors/wrist_wrench": 300} and report.damaged_end is None
    assert report.kept.chunks < before.chunks  # compacted
    values = read_scalars(out, f"{WRENCH}/force_n/0")[f"{WRENCH}/force_n/0"][1]
    assert values.tolist() == [float(i) for i in range(300)]
    assert "kept 300 bus messages on 1 key," in report.line() and "nothing dropped" in report.line()
    # A second run changes nothing.
    data = out.read_bytes()
    again = finalise(out)
    assert again.already_finalised and out.read_bytes() == data


def test_a_file_cut_off_mid_message_keeps_every_complete_message(tmp_path):
    """A SIGKILL while the file sink writes: the file ends inside the last message."""
    out = tmp_path / "live.rrd"
    writer = RecordingWriter(out, PREFIX, RecorderConfig(robot_model="none"))
    sizes = []
    for flush in range(3):
        for i in range(50 * flush, 50 * flush + 50):
            writer.add(topics.WRIST_WRENCH, _wrench(i), 1_000_000 * (i + 1))
        writer.pump(force=True)  # blocking: the file holds the flush when it returns
        sizes.append(out.stat().st_size)
    cut = tmp_path / "killed.rrd"
    cut.write_bytes(out.read_bytes()[:(sizes[1] + sizes[2]) // 2])  # inside the third flush's batch
    writer.close(finalise=False)
    assert _verify(cut).returncode == 1

    report = finalise(cut)

    assert _verify(cut).returncode == 0
    assert report.kept.bus_messages() == {"sensors/wrist_wrench": 100}  # the two complete flushes
    assert report.damaged_end is not None and "exceeds file size" in report.damaged_end
    assert "incomplete last message was dropped" in report.line()
    values = read_scalars(cut, f"{WRENCH}/force_n/0")[f"{WRENCH}/force_n/0"][1]
    assert np.array_equal(values, np.arange(100, dtype=float))


@pytest.mark.parametrize("content", [b"", b"not a recording\n", b"RRF2"])
def test_what_is_not_a_recording_is_refused_and_left_unchanged(tmp_path, content):
    path = tmp_path / "notes.rrd"
    path.write_bytes(content)
    with pytest.raises(RecordingUnreadable) as raised:
        finalise(path)
    assert "left unchanged" in str(raised.value) and "\n" not in str(raised.value)
    assert path.read_bytes() == content
    assert [p.name for p in tmp_path.iterdir()] == ["notes.rrd"]  # no work folder left behind


def test_a_missing_file_is_a_usage_error(tmp_path):
    with pytest.raises(RecorderError) as raised:
        finalise(tmp_path / "nope.rrd")
    assert raised.value.bad_input  # exit 2


def test_readback_counts_are_unchanged_by_finalising(tmp_path):
    out = tmp_path / "rows.rrd"
    writer = RecordingWriter(out, PREFIX, RecorderConfig(robot_model="none"))
    for i in range(40):
        writer.add(topics.WRIST_WRENCH, _wrench(i), 1_000_000 * (i + 1))
        writer.pump(force=True)  # 40 one-row chunks
    writer.close(finalise=False)
    temporal = entity_row_counts(out, include_static=False)
    finalise(out)
    assert entity_row_counts(out, include_static=False) == temporal
