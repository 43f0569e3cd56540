"""`handover-recorder screenshot`: what it refuses before any work (one line, exit 2, nothing
written), and how it finds the arm a recording draws."""

from __future__ import annotations

import pytest

from services.recorder.cli import main
from services.recorder.errors import RecorderError
from services.recorder.screenshot import check_paths, parse_size, recorded_robot


def test_a_size_is_two_numbers_of_pixels():
    assert parse_size("1600x1000") == (1600, 1000)
    assert parse_size("16x16384") == (16, 16384)
    for bad in ("1600", "1600x", "x1000", "1600X1000", "10x1000", "1600x20000", "-5x100", "16.5x100", ""):
        with pytest.raises(RecorderError, match="must look like 1600x1000"):
            parse_size(bad)


def test_the_arm_is_the_root_of_the_urdf_entities():
    entities = ["/bus/gripper/command", "/world/object", "/panda/visual_geometries/link0/visual_0",
                "/panda/collision_geometries/mesh/link1/collision_0"]
    assert recorded_robot(entities) == "panda"
    assert recorded_robot(["/baxter/collision_geometries/box/x/collision_0"]) == "baxter"
    assert recorded_robot(["/bus/robot/joint_state", "/world/visual_geometries"]) is None  # no arm model
    assert recorded_robot([]) is None


def test_paths_are_checked_before_any_work(tmp_path):
    recording = tmp_path / "run.rrd"
    with pytest.raises(RecorderError, match="does not exist"):
        check_paths(recording, tmp_path / "out.png")
    recording.write_bytes(b"x")
    with pytest.raises(RecorderError, match="must end in .png"):
        check_paths(recording, tmp_path / "out.jpg")
    (tmp_path / "file").write_text("")
    with pytest.raises(RecorderError, match="is not a folder"):
        check_paths(recording, tmp_path / "file" / "out.png")
    check_paths(recording, tmp_path / "new" / "out.png")  # a folder still to make is fine


@pytest.mark.parametrize("args, said", [
    (["missing.rrd"], "does not exist"),
    (["{rec}", "--output", "{out}.jpg"], "must end in .png"),
    (["{rec}", "--size", "big"], "must look like 1600x1000"),
])
def test_the_command_refuses_bad_input_in_one_line_with_exit_2_and_writes_nothing(tmp_path, capsys, args, said):
    recording = tmp_path / "run.rrd"
    recording.write_bytes(b"not read: refused first")
    out = tmp_path / "shot"
    argv = ["screenshot", *[a.format(rec=recording, out=out) for a in args], *(
        ["--output", f"{out}.png"] if "--output" not in args else [])]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and said in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.rrd"]
    assert recording.read_bytes() == b"not read: refused first"
