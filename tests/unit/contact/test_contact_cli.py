"""CLI of the contact simulator."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from services.studies.contact_command import main


def test_episode_writes_json_and_plot(tmp_path, capsys):
    out, png = tmp_path / "ep.json", tmp_path / "ep.png"
    code = main(["episode", "--behaviour", "dropping", "--controller", "release-after", "--release-at-s", "1.2",
                 "--duration-s", "2.5", "--json", str(out), "--plot", str(png)])
    assert code == 0
    doc = json.loads(out.read_text())
    assert doc["dropped"] is True and doc["handed_over"] is False
    assert doc["mode_timeline"][0][1] == "GRASP" and doc["mode_timeline"][-1][1] == "RELEASE"
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    assert "dropped       True" in capsys.readouterr().out


def test_external_controller_by_import_path(tmp_path):
    out = tmp_path / "ep.json"
    code = main(["episode", "--behaviour", "absent", "--controller", "robot_sim.contact.controllers:ConstantGrip",
                 "--duration-s", "0.5", "--json", str(out)])
    assert code == 0
    doc = json.loads(out.read_text())
    # ConstantGrip() holds 10 N > W / mu_s: nothing moves.
    assert doc["released"] is False and doc["slip_distance_m"] == 0.0 and doc["mode_switch_count"] == 0


def test_drag_with_a_fast_gripper_and_a_wide_batch(tmp_path, capsys):
    out = tmp_path / "ep.json"
    # A drag released at 1.3 s ends in the receiver's hand; the fast gripper releases it sooner.
    for rate, loop in (("50", "25"), ("500", "250")):
        assert main(["episode", "--behaviour", "drag", "--controller", "release-after", "--grip-n", "40",
                     "--release-at-s", "1.3", "--force-rate-n-s", rate, "--loop-rate-hz", loop, "--duration-s", "3",
                     "--json", str(out)]) == 0
        doc = json.loads(out.read_text())
        assert doc["handed_over"] is True and doc["dropped"] is False
        if rate == "50":
            slow_release = doc["release_time_s"]
    assert doc["release_time_s"] < slow_release - 0.1  # 40 N to 0: 0.8 s at 50 N/s, 0.08 s at 500 N/s
    assert main(["batch", "--behaviour", "mixed-wide", "-n", "6", "--workers", "1", "--chunk-size", "6",
                 "--duration-s", "1.0", "--no-progress", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["episodes"] == 6


def test_batch_summary(tmp_path, capsys):
    out = tmp_path / "b.json"
    code = main(["batch", "--behaviour", "dropping", "-n", "10", "--workers", "1", "--chunk-size", "10",
                 "--controller", "constant", "--grip-n", "60", "--duration-s", "2.5", "--no-progress",
                 "--json", str(out)])
    assert code == 0
    doc = json.loads(out.read_text())
    assert doc["episodes"] == 10 and doc["drop_rate"] == 0.0 and doc["released_rate"] == 0.0


@pytest.mark.parametrize("argv, words", [
    (["episode", "--controller", "nope"], "unknown controller"),
    (["episode", "--controller", "no.such.module:X"], "cannot load controller"),
    (["batch", "-n", "0"], "n_episodes must be >= 1"),
    (["episode", "--dt-s", "0.5"], "dt_s"),
    (["episode", "--loop-rate-hz", "150"], "whole number of plant steps"),
])
def test_bad_input_one_line_error(argv, words, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and "\n" not in err


def test_nan_argument_rejected(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["episode", "--grip-n", "nan"])
    assert exc.value.code == 2


def test_module_entry_point_help():
    proc = subprocess.Popen([sys.executable, "-m", "robot_sim.contact", "--help"], stdout=subprocess.PIPE, text=True)
    try:
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0 and "episode" in out and "batch" in out
