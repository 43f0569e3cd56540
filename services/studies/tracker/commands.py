"""`handover-study record` and `handover-study evaluate`: the tracker's offline studies.

    handover-study record --out FILE [--seed N]        one simulated episode to a replay file
    handover-study evaluate [--episodes N] [--figure F] hand error vs the simulator's truth

A replay file feeds `handover-tracker offline FILE` and `handover-tracker --replay FILE`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from services.runtime.cli import positive_int
from services.tracker.config_args import add_config_flags, config_from_args, profile_config

RECORD_DESCRIPTION = "Simulate one seeded tracker episode (Kinect, joints, truth) and write a replay file."
DEFAULTS_DESCRIPTION = ("Choose the tracker's correction settings on selection seeds and confirm the choice "
                        "on other seeds (the evidence behind the shipped defaults).")
EVALUATE_DESCRIPTION = ("Hand-position error of the tracker against the simulator's truth, per Mincelli "
                        "correction and handover phase, over seeded episodes.")



def add_record_arguments(p: argparse.ArgumentParser) -> None:
    """Flags of `record`."""
    p.add_argument("--out", type=Path, required=True, help="replay file to write")
    p.add_argument("--seed", type=int, default=0, help="episode seed")


def run_record(args: argparse.Namespace) -> int:
    """Simulate one episode and write every frame's joints, depth, skeleton and truth."""
    from bus_schema import topics as T
    from services.studies.tracker.episodes import run_episode
    from services.tracker.replay import ReplayWriter

    if args.out.parent and not args.out.parent.is_dir():
        print(f"handover-study record: error: folder {args.out.parent} does not exist", file=sys.stderr)
        return 2
    frames = 0
    with ReplayWriter(args.out) as writer:
        for frame in run_episode(args.seed):
            writer.write(frame.t_s, T.JOINT_STATE, frame.joint_state)
            writer.write(frame.t_s, T.DEPTH, frame.depth)
            writer.write(frame.t_s, T.SKELETON, frame.skeleton)
            writer.write(frame.t_s, T.SIM_TRUTH, frame.truth)
            frames += 1
    size_mb = args.out.stat().st_size / 1e6
    print(f"recorded episode seed {args.seed}: {frames} frames, {writer.records} messages, "
          f"{size_mb:.1f} MB -> {args.out}")
    return 0


def add_evaluate_arguments(p: argparse.ArgumentParser) -> None:
    """Flags of `evaluate`: the episodes, the outputs, the profile and the tracker's own flags."""
    p.add_argument("--episodes", type=positive_int, default=20, help="number of seeded episodes")
    p.add_argument("--seed", type=int, default=0, help="first seed")
    p.add_argument("--json", type=Path, default=Path("out/tracker/evaluation.json"), help="results file")
    p.add_argument("--figure", type=Path, default=None,
                   help="write the raw-vs-corrected figure of the first episode here")
    p.add_argument("--profile", default="sim",
                   help="profile whose [services.tracker.config] is the starting point (default: sim)")
    add_config_flags(p)


def run_evaluate(args: argparse.Namespace) -> int:
    """Run the evaluation, print its table and write the results (and the figure)."""
    from services.studies.tracker.evaluate import markdown_table, plot_trace, run_evaluation, write_results

    config = config_from_args(args, profile_config(args))
    summary, trace = run_evaluation(args.episodes, args.seed, config, progress=sys.stderr.isatty())
    print(markdown_table(summary))
    write_results(summary, args.json, args.episodes, args.seed)
    print(f"\nresults: {args.json}")
    if args.figure is not None and trace is not None:
        plot_trace(trace, args.figure)
        print(f"figure: {args.figure}")
    return 0


def add_defaults_arguments(p: argparse.ArgumentParser) -> None:
    """Flags of `tracker-defaults`."""
    p.add_argument("--episodes", type=positive_int, default=16, help="episodes per seed set")
    p.add_argument("--select-seed", type=int, default=0, help="first seed of the selection set")
    p.add_argument("--confirm-seed", type=int, default=1000, help="first seed of the confirmation set")
    p.add_argument("--json", type=Path, default=Path("out/tracker/defaults.json"), help="results file")


def run_defaults(args: argparse.Namespace) -> int:
    """Evaluate every candidate on both seed sets; print the tables, the choice and whether it holds."""
    import json

    from services.studies.tracker.defaults import best, evaluate_candidates
    from services.studies.tracker.evaluate import markdown_table
    from services.tracker.config import TrackerConfig

    if abs(args.select_seed - args.confirm_seed) < args.episodes:
        print("handover-study tracker-defaults: error: the selection and confirmation seeds overlap", file=sys.stderr)
        return 2
    base = TrackerConfig()
    sets = {"selection": range(args.select_seed, args.select_seed + args.episodes),
            "confirmation": range(args.confirm_seed, args.confirm_seed + args.episodes)}
    out = {}
    for label, seeds in sets.items():
        summary = evaluate_candidates(seeds, base, progress=sys.stderr.isatty())
        out[label] = {"seeds": [seeds.start, seeds.stop - 1], "summary": summary, "best": best(summary)}
        print(f"\n{label} seeds {seeds.start}–{seeds.stop - 1}:\n{markdown_table(summary)}")
    chosen, confirmed = out["selection"]["best"], out["confirmation"]["best"]
    print(f"\nchosen on the selection seeds: {chosen}; best on the confirmation seeds: {confirmed} "
          f"({'the choice holds' if chosen == confirmed else 'the choice does NOT hold'})")
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(out, indent=2))
    print(f"results: {args.json}")
    return 0 if chosen == confirmed else 1
