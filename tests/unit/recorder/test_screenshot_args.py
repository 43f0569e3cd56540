"""`handover-recorder screenshot`: what it refuses before any work (one line, exit 2, nothing
written), and how it finds the arm a recording draws."""

from __future__ import annotations

import pytest

from services.recorder.cli import main
from services.recorder.errors import RecorderError
from services.recorder.screenshot import _layout, check_paths, parse_size, recorded_arm, recorded_robot


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
    with pytest.raises(RecorderError, match="cannot write into"):
        check_paths(recording, tmp_path / "file" / "out.png")
    (tmp_path / "dir.png").mkdir()
    with pytest.raises(RecorderError, match="is a folder"):
        check_paths(recording, tmp_path / "dir.png")
    check_paths(recording, tmp_path / "new" / "out.png")  # a folder still to make is made
    assert (tmp_path / "new").is_dir()


def test_the_recorded_arm_is_found_by_its_urdf_name():
    assert recorded_arm("baxter").name == "baxter"
    assert recorded_arm("panda").name == "panda"
    assert recorded_arm("so101_new_calib").name == "so_arm101"  # its URDF's own name
    assert recorded_arm("no_such_arm") is None and recorded_arm(None) is None


@pytest.fixture
def active_arm_restored():
    from handover_model import robots

    previous = robots.active()
    yield
    robots.use(previous)


def test_the_layout_is_the_recorded_arms(tmp_path, monkeypatch, active_arm_restored):
    """A Panda recording drawn in a process whose arm is Baxter: the layout is built with the
    Panda active, so what it hides is the Panda's (its collision meshes are its drawn hulls)."""
    import rerun as rr

    from handover_model import robots
    from services.recorder import blueprint as blueprint_module

    recording = tmp_path / "panda.rrd"
    rec = rr.RecordingStream("handover")
    rec.save(str(recording))
    rec.log("/panda/visual_geometries/panda_link0/visual_0", rr.Points3D([[0.0, 0.0, 0.0]]), static=True)
    rec.log("/world/object", rr.Points3D([[0.1, 0.0, 0.0]]), static=True)
    rec.flush()
    rec.disconnect()
    robots.use(robots.describe("baxter"))
    seen = []
    real = blueprint_module.blueprint
    monkeypatch.setattr(blueprint_module, "blueprint",
                        lambda name, **kw: seen.append((name, robots.active().name)) or real(name, **kw))
    _layout(recording, tmp_path / "layout.rbl")
    assert seen == [("panda", "panda")]
    assert (tmp_path / "layout.rbl").stat().st_size > 0
    hidden = set(blueprint_module._robot_overrides("panda"))
    assert "panda/collision_geometries/mesh" not in hidden and "panda/collision_geometries/sphere" in hidden


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
