"""Command line of the contact simulator: one episode (with a plot), a batch, the doc figures.

    handover-contact episode --behaviour taking --controller release-after --plot out/ep.png
    handover-contact batch --behaviour mixed -n 10000 --workers 2 --json out/batch.json
    handover-contact figures --out docs/img

`handover-contact` (`services.studies.contact_command`) is this command line with an engine
(`BatchEngine`: the studies' Dask engine, flags --workers, --address, --checkpoint) that runs a
batch's chunks; `python -m robot_sim.contact` is the same without one: batches run in this
process (robot_sim never imports the services).
"""

from __future__ import annotations

import argparse
import functools
import importlib
import json
import logging
import math
import sys
from dataclasses import replace
from pathlib import Path
from typing import Callable, Protocol

from robot_sim.contact.batch import MapTasks, run_batch
from robot_sim.contact.config import ContactSimError, GripperParams, SensorParams, SimConfig
from robot_sim.contact.controllers import ConstantGrip, ReleaseAfter
from robot_sim.contact.episode import run_episode
from handover_model.grip import GripController
from robot_sim.contact.receiver import behaviour_by_name

log = logging.getLogger("robot_sim.contact")

BEHAVIOURS = ("taking", "pull-first", "drag", "dropping", "bumping", "hesitating", "absent")


def _finite(kind):
    def parse(text: str):
        v = kind(text)
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
        return v
    return parse


class BatchEngine(Protocol):
    """What runs a batch's chunks elsewhere: its flags, and from them the mapping function
    (`robot_sim.contact.batch.MapTasks`) and the number of worker processes (None: unknown,
    a cluster's)."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None: ...

    def mapper(self, args: argparse.Namespace) -> tuple[MapTasks, int | None]: ...


def _controller_factory(args) -> Callable[[], GripController]:
    """The controller; the built-in ones step at the setup's control period (the faster of
    the F/T sensor and the gripper loop)."""
    name = args.controller
    period_s = _config(args).control_period_s
    if name == "constant":
        return functools.partial(ConstantGrip, args.grip_n, period_s=period_s)
    if name == "release-after":
        return functools.partial(ReleaseAfter, args.grip_n, args.release_at_s, period_s=period_s)
    if ":" in name:
        module, _, attr = name.partition(":")
        try:
            factory = getattr(importlib.import_module(module), attr)
        except (ImportError, AttributeError) as exc:
            raise ContactSimError(f"cannot load controller {name!r} ({exc}); give MODULE:CALLABLE, "
                                  "e.g. robot_sim.contact.controllers:ConstantGrip") from None
        return factory
    raise ContactSimError(f"unknown controller {name!r}; use constant, release-after, or MODULE:CALLABLE")


def _config(args) -> SimConfig:
    sensors = SensorParams(accel_noise_snr_db=args.accel_snr_db, grip_noise_snr_db=args.grip_snr_db,
                           optical_report_rate_hz=args.optical_rate_hz)
    cfg = SimConfig(gripper=GripperParams(open_gap_m=args.open_gap_m), sensors=sensors,
                    dt_s=args.dt_s, duration_s=args.duration_s)
    return cfg.with_gripper_rates(args.force_rate_n_s, args.loop_rate_hz)


def _add_common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--controller", default="constant",
                   help="constant | release-after | MODULE:CALLABLE building a GripController (default constant)")
    p.add_argument("--grip-n", type=_finite(float), default=10.0, help="grip force of constant/release-after, N (10)")
    p.add_argument("--release-at-s", type=_finite(float), default=1.5, help="release time of release-after, s (1.5)")
    p.add_argument("--open-gap-m", type=_finite(float), default=0.0,
                   help="finger gap behind the contact point for a 0 N command, m (0 = thesis spring gripper)")
    p.add_argument("--accel-snr-db", type=_finite(float), default=None, help="noise on a_y at this SNR, dB (thesis: 3)")
    p.add_argument("--grip-snr-db", type=_finite(float), default=None, help="noise on the grip command at this SNR, dB")
    p.add_argument("--force-rate-n-s", type=_finite(float), default=50.0,
                   help="gripper force rate (finger speed limit × spring), N/s (50)")
    p.add_argument("--loop-rate-hz", type=_finite(float), default=25.0,
                   help="gripper position-loop rate, Hz (25); above 100 Hz the F/T sensor and the built-in "
                        "controllers run at it too")
    p.add_argument("--optical-rate-hz", type=_finite(float), default=100.0, help="optical sensor read rate, Hz (100)")
    p.add_argument("--dt-s", type=_finite(float), default=0.001, help="plant step, s (0.001)")
    p.add_argument("--duration-s", type=_finite(float), default=3.5, help="episode length, s (3.5)")
    p.add_argument("--seed", type=int, default=0, help="random seed (0)")
    p.add_argument("--json", type=Path, default=None, help="write the result as JSON to this file")


class _OneLineParser(argparse.ArgumentParser):
    """Errors as one line (``handover-contact: error: …``) and exit 2, as every command of the stack."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message} (see --help)\n")
        raise SystemExit(2)


def build_parser(engine: BatchEngine | None = None) -> argparse.ArgumentParser:
    parser = _OneLineParser(prog="handover-contact",
                                     description="Contact simulator of the handover transfer phase: one "
                                                 "episode, a batch, or the thesis's figures.")
    parser.add_argument("--log-level", default="WARNING", choices=["DEBUG", "INFO", "WARNING", "ERROR"])
    sub = parser.add_subparsers(dest="command", required=True)
    ep = sub.add_parser("episode", help="run one episode, print its outcome, optionally plot it")
    ep.add_argument("--behaviour", choices=BEHAVIOURS, default="taking")
    ep.add_argument("--phi-deg", type=_finite(float), default=None,
                    help="pull angle φ, degrees, > 0 pulls down (default: the behaviour's own)")
    ep.add_argument("--plot", type=Path, default=None, help="write a PNG of the episode here")
    _add_common(ep)
    bt = sub.add_parser("batch", help="run many randomised episodes in parallel and summarise")
    bt.add_argument("--behaviour", choices=BEHAVIOURS[:-1] + ("mixed", "mixed-wide"), default="mixed")
    bt.add_argument("-n", "--episodes", type=int, default=1000, help="number of episodes (1000)")
    bt.add_argument("--chunk-size", type=int, default=500, help="episodes per vectorised chunk (500)")
    bt.add_argument("--no-progress", action="store_true", help="no progress bar")
    _add_common(bt)
    if engine is not None:
        engine.add_arguments(bt)
    fg = sub.add_parser("figures", help="write the documentation figures (one taking, one dropping episode)")
    fg.add_argument("--out", type=Path, default=Path("docs/img"), help="folder for the PNGs (docs/img)")
    return parser


def _write_json(path: Path | None, payload: dict) -> None:
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(payload, indent=2, default=float) + "\n")


def _episode(args) -> int:
    cfg = _config(args)
    kwargs = {"weight_n": cfg.obj.weight_n}
    if args.phi_deg is not None:
        if args.behaviour == "absent":
            raise ContactSimError("--phi-deg has no meaning for the absent receiver")
        kwargs["pull_angle_rad"] = math.radians(args.phi_deg)
    beh = behaviour_by_name(args.behaviour, **kwargs)
    res = run_episode(cfg, beh, _controller_factory(args)(), seed=args.seed, label=args.behaviour)
    o = res.outcome
    print(f"episode  behaviour={args.behaviour} controller={args.controller} seed={args.seed}")
    print(f"released      {o.released}" + (f" at {o.release_time_s:.3f} s" if o.released else ""))
    print(f"dropped       {o.dropped}" + (f" at {o.drop_time_s:.3f} s" if o.dropped else ""))
    print(f"handed over   {o.handed_over}")
    print(f"overshoot     {o.force_overshoot_n:.2f} N")
    print(f"slip          {1000 * o.slip_distance_m:.1f} mm")
    print(f"peak a_y      {o.peak_down_accel_m_s2:.2f} m/s^2")
    print("modes         " + " -> ".join(f"{m.name}@{t:.3f}s" for t, m in o.mode_timeline))
    if args.plot is not None:
        from robot_sim.contact.plot import plot_episode
        print(f"plot          {plot_episode(res.trace, o, args.plot, title=f'{args.behaviour}, {args.controller}')}")
    _write_json(args.json, o.to_dict())
    return 0


def _batch(args, engine: BatchEngine | None) -> int:
    cfg = _config(args)
    map_tasks, workers = engine.mapper(args) if engine is not None else (None, 1)
    res = run_batch(cfg, args.behaviour, args.episodes, _controller_factory(args), seed=args.seed,
                    chunk_size=args.chunk_size, progress=not args.no_progress, map_tasks=map_tasks, workers=workers)
    summary = res.outcome.summary()
    summary.update(wall_time_s=res.wall_time_s, episodes_per_s=res.episodes_per_s, workers=res.workers,
                   behaviour=args.behaviour, controller=args.controller, seed=args.seed)
    if res.workers is None:
        summary["workers"] = f"cluster {args.address}"
    width = max(len(k) for k in summary)
    for k, v in summary.items():
        print(f"{k:<{width}}  {v:.4g}" if isinstance(v, float) else f"{k:<{width}}  {v}")
    _write_json(args.json, summary)
    return 0


def _figures(args) -> int:
    from robot_sim.contact.plot import plot_episode
    cfg = SimConfig(duration_s=3.5)
    take = behaviour_by_name("taking", pull_angle_rad=0.0, transfer_s=0.5)
    res = run_episode(cfg, take, ConstantGrip(10.0), seed=1)
    print(plot_episode(res.trace, res.outcome, args.out / "contact_taking.png",
                       title="taking (φ = 0), constant 10 N grip: the receiver pulls it out of the pads"))
    drop = behaviour_by_name("dropping", pull_angle_rad=0.0)
    cfg_open = replace(cfg, gripper=GripperParams(open_gap_m=0.0))
    res = run_episode(cfg_open, drop, ReleaseAfter(10.0, 1.2), seed=1)
    print(plot_episode(res.trace, res.outcome, args.out / "contact_dropping.png",
                       title="dropping (φ = 0, weight not supported), open-loop release at 1.2 s"))
    return 0


def main(argv: list[str] | None = None, engine: BatchEngine | None = None) -> int:
    """Entry point; returns the process exit code (2 on bad input). With `engine`, batches run
    on it (its errors are its caller's to report)."""
    parser = build_parser(engine)
    args = parser.parse_args(argv)
    logging.basicConfig(level=args.log_level, format="%(levelname)s %(name)s: %(message)s")
    try:
        if args.command == "episode":
            return _episode(args)
        if args.command == "batch":
            return _batch(args, engine)
        return _figures(args)
    except ContactSimError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
