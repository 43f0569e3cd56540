"""The release controllers closed-loop on MuJoCo (`robot_sim.contact.crosscheck.closed_loop`)
against our plant, and the study around it (`services.studies.gripper.mujoco_loop*`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="the `mujoco` wheel is not installed here: the MuJoCo closed loop cannot run")

from handover_model.grip import Mode  # noqa: E402
from robot_sim.contact.config import ObjectParams, SensorParams, SimConfig  # noqa: E402
from robot_sim.contact.crosscheck.closed_loop import run_mujoco_episode  # noqa: E402
from robot_sim.contact.episode import run_episode  # noqa: E402
from robot_sim.contact.outcome import BatchOutcome  # noqa: E402
from robot_sim.contact.receiver import absent, dropping, taking  # noqa: E402
from services.gripper.controllers.registry import make_controller  # noqa: E402
from services.studies.cli import main  # noqa: E402
from services.studies.gripper.episodes import sample_chunk  # noqa: E402
from services.studies.gripper.mujoco_loop import LoopResult, episode_spec  # noqa: E402
from services.studies.gripper.mujoco_loop_command import DEFAULT_CONTROLLERS  # noqa: E402
from services.studies.gripper.mujoco_loop_stats import flips, mcnemar_rows  # noqa: E402
from services.studies.gripper.populations import plan_chunks, population  # noqa: E402

EQUAL_MU = ObjectParams(mu_static=0.6, mu_kinetic=0.6)


def _config(duration_s: float, **sensors) -> SimConfig:
    return SimConfig(obj=EQUAL_MU, duration_s=duration_s, sensors=replace(SensorParams(), **sensors))


def _both(config: SimConfig, receiver, name: str, seed: int = 3):
    ours = run_episode(config, receiver, make_controller(name, period_s=config.control_period_s), seed=seed)
    mj = run_mujoco_episode(config, receiver, make_controller(name, period_s=config.control_period_s), seed=seed)
    return ours, mj


@pytest.mark.parametrize("name", DEFAULT_CONTROLLERS)
def test_every_controller_keeps_an_object_nobody_touches_on_mujoco(name):
    config = _config(1.0)
    res = run_mujoco_episode(config, absent(config.obj.weight_n), make_controller(name), seed=1)
    o = res.outcome
    assert not o.dropped and not o.released
    assert not np.any(res.trace.mode == Mode.RELEASE)
    assert np.max(np.abs(res.trace.object_position_y_m)) < 2e-4  # only MuJoCo's creep, no slide


def test_sg_hands_a_taking_receiver_the_object_on_mujoco():
    config = _config(2.5)
    res = run_mujoco_episode(config, taking(weight_n=config.obj.weight_n), make_controller("SG"), seed=2)
    o = res.outcome
    assert o.released and o.handed_over and not o.dropped
    assert 1.0 < o.release_time_s < 2.0


@pytest.mark.parametrize(("receiver", "name", "dropped"), [(taking(), "SG", False), (dropping(), "HI", True)],
                         ids=["taking-SG", "dropping-HI"])
def test_both_plants_give_the_same_verdict_times_and_force_peak(receiver, name, dropped):
    """Equal μ_k = μ_s, the same receiver, controller and noise: the same verdict, release and
    drop times within 5 ms and the force overshoot within 2 %."""
    ours, mj = _both(_config(2.5), receiver, name)
    a, b = ours.outcome, mj.outcome
    assert (a.dropped, a.handed_over, a.released) == (b.dropped, b.handed_over, b.released)
    assert a.dropped is dropped
    assert b.release_time_s == pytest.approx(a.release_time_s, abs=0.005)
    assert b.force_overshoot_n == pytest.approx(a.force_overshoot_n, rel=0.02)
    if dropped:
        assert b.drop_time_s == pytest.approx(a.drop_time_s, abs=0.005)


def test_the_wrist_reads_the_weight_and_the_optical_sensor_reads_nothing_at_rest():
    """Noise-free sensors on a held object: F_y = W, F_x = 0 from MuJoCo's constraint forces;
    the optical sensor sees the surface and at most one count of MuJoCo's creep."""
    config = _config(0.5, ft_noise_std_n=0.0, ft_bias_std_n=0.0)
    res = run_mujoco_episode(config, absent(config.obj.weight_n), make_controller("SG"), seed=0)
    t = res.trace
    assert t.sensed_force_y_n[1:] == pytest.approx(config.obj.weight_n, abs=2e-3)
    assert np.max(np.abs(t.sensed_force_x_n)) < 1e-9
    assert t.optical_valid.all()
    assert t.object_velocity_y_m_s[-1] == pytest.approx(0.0, abs=2e-4)


def test_both_plants_draw_the_same_sensor_noise():
    """Same seed: the F/T readings of both plants differ by the (tiny) load difference, not
    by the noise (σ 0.15 N, bias σ 0.05 N)."""
    config = _config(0.5, ft_noise_std_n=0.15, ft_bias_std_n=0.05)
    ours, mj = _both(config, absent(config.obj.weight_n), "HI", seed=11)
    assert np.std(ours.trace.sensed_force_y_n) > 0.05
    assert mj.trace.sensed_force_y_n == pytest.approx(ours.trace.sensed_force_y_n, abs=2e-3)
    assert mj.trace.sensed_force_x_n == pytest.approx(ours.trace.sensed_force_x_n, abs=1e-6)


def test_an_episode_is_the_benchmarks_with_mu_k_equal_to_mu_s():
    dist = population("narrow")
    plans = plan_chunks(dist, 30, 10, 5)
    seq = plans[1].seed
    draw, _ = np.random.SeedSequence(seq.entropy, spawn_key=seq.spawn_key).spawn(2)
    chunk = sample_chunk(dist, 10, np.random.default_rng(draw), gripper=plans[1].gripper, kinds=plans[1].kinds)
    spec = episode_spec(dist, 30, 10, 5, 13)
    assert spec.index == 13
    assert spec.config.obj.mass_kg == chunk.mass_kg[3]
    assert spec.config.obj.mu_static == spec.config.obj.mu_kinetic == chunk.mu_static[3]
    assert spec.receiver == chunk.receivers.episode(3)


def _outcome(dropped, handed):
    n = len(dropped)
    z = np.zeros(n)
    return BatchOutcome(released=np.array(handed, bool), release_time_s=z, dropped=np.array(dropped, bool),
                        drop_time_s=z, handed_over=np.array(handed, bool), force_overshoot_n=z, slip_distance_m=z,
                        peak_down_accel_m_s2=z, mode_switch_count=np.zeros(n, np.int64),
                        final_mode=np.zeros(n, np.int8))


def test_flips_and_mcnemar_name_the_disagreeing_episodes():
    draws = {"index": np.arange(10, 14), "kind": np.array([0, 1, 0, 1]), "behaviour": np.array([0, 1, 0, 1]),
             "grasp_start_s": np.zeros(4), "mass_kg": np.full(4, 0.2), "mu": np.full(4, 0.5),
             "pull_angle_rad": np.zeros(4)}
    res = LoopResult(
        outcomes={"SG": {"ours": _outcome([0, 1, 0, 0], [1, 0, 0, 0]), "mujoco": _outcome([0, 0, 1, 0], [1, 0, 1, 0])},
                  "HI": {"ours": _outcome([1, 1, 1, 1], [0, 0, 0, 0]), "mujoco": _outcome([1, 1, 1, 1], [0, 0, 0, 0])}},
        holds_at_release={}, draws=draws, wall_s={"ours": 1.0, "mujoco": 2.0}, seed=1, population="narrow")
    by = {(f.controller, f.kind): f for f in flips(res)}
    assert by[("SG", "all")].ours_only_drops == (11,) and by[("SG", "all")].mujoco_only_drops == (12,)
    assert by[("SG", "taking")].handover_flips == (12,) and by[("SG", "dropping")].drop_flips == 1
    assert by[("HI", "all")].drop_flips == 0
    tests = {(t["test"], t["controller"]): t for t in mcnemar_rows(res)}
    assert (tests[("ours vs MuJoCo", "SG")]["only_a_drops"], tests[("ours vs MuJoCo", "SG")]["only_b_drops"]) == (1, 1)
    assert tests[("vs SG on ours", "HI")]["only_a_drops"] == 3
    assert res.episodes_per_s("mujoco") == pytest.approx(4.0)


@pytest.mark.parametrize("argv", [["--controllers", "SG", "nope"], ["-n", "5", "--replay", "5"], ["-n", "0"],
                                  ["--population", "huge"]], ids=["controller", "replay", "episodes", "population"])
def test_bad_input_exits_2_with_one_line_and_writes_nothing(argv, tmp_path, capsys):
    out = tmp_path / "out"
    try:
        code = main(["crosscheck-loop", "--out", str(out), "--workers", "1", "--no-progress", *argv])
    except SystemExit as exc:  # argparse's own usage errors
        code = exc.code
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "crosscheck-loop" in err
    assert not out.exists()


def test_a_doc_without_the_region_is_refused(tmp_path, capsys):
    doc = tmp_path / "page.md"
    doc.write_text("# no region here\n")
    code = main(["crosscheck-loop", "-n", "1", "--doc", str(doc), "--out", str(tmp_path / "out"), "--workers", "1"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "crosscheck-loop-table" in err and len(err.splitlines()) == 1
    assert doc.read_text() == "# no region here\n" and not (tmp_path / "out").exists()
