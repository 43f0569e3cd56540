"""An evaluation run: its folder, its manifest, the episodes on the engine, the report.

The run folder holds ``manifest.json`` (seed, base profile, episodes, timeout: what makes the
run reproducible), ``episodes/eNNNN/`` (one per episode: profile, console, recording, logs,
``record.json``), the engine's checkpoint and ``report/``. Nothing is lost on a crash: every
episode's record is written when it ends, and ``--resume`` runs only the episodes without one.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from services.studies.evaluation.episode_profile import read_base_profile
from services.studies.evaluation.errors import EvaluationError
from services.studies.evaluation.report import write_report
from services.studies.evaluation.runner import EpisodeTask, read_record, run_episode, write_json
from services.studies.evaluation.stats import format_rate
from services.studies.evaluation.summary import summarise

MANIFEST = "manifest.json"


@dataclass(frozen=True)
class RunOptions:
    """What `handover-eval run` was asked (None: the default, or the resumed run's value)."""

    out: Path
    episodes: int | None
    seed: int | None
    profile: str | None
    workers: int | None
    address: str | None
    timeout_s: float
    resume: bool
    show_progress: bool = True
    clock: str | None = None
    robot: str | None = None


def read_manifest(run_dir: Path) -> dict[str, Any]:
    """The run's manifest.

    Raises:
        EvaluationError: (bad input) the folder holds no evaluation run.
    """
    try:
        return json.loads((run_dir / MANIFEST).read_text())
    except (OSError, ValueError) as exc:
        raise EvaluationError(f"{run_dir} holds no evaluation run ({MANIFEST}: "
                              f"{getattr(exc, 'strerror', None) or exc}); check --run/--out", bad_input=True) from None


def _manifest(options: RunOptions) -> dict[str, Any]:
    """The manifest of the run (a new one, or the resumed one with `options` applied)."""
    out = options.out
    if options.resume:
        manifest = read_manifest(out)
        for name in ("seed", "profile", "clock", "robot"):
            given = getattr(options, name)
            # A run from before --clock ran on the wall clock; one from before --robot, the profile's arm.
            kept = str(manifest.get(name, "wall" if name == "clock" else None))
            if name == "profile" and given is not None:  # the manifest keeps the resolved path
                given = str(read_base_profile(given)[0].resolve())
            if given is not None and str(given) != kept:
                raise EvaluationError(f"--{name} {given} differs from the resumed run's ({kept}); drop it "
                                      "or start a new run in another --out", bad_input=True)
        if options.episodes is not None:
            manifest["episodes"] = options.episodes  # more (or fewer): the same seed draws the same episodes
        read_base_profile(manifest["profile"])
        return manifest
    if (out / MANIFEST).exists():
        raise EvaluationError(f"--out {out} already holds a run: continue it with --resume, or choose another "
                              "folder", bad_input=True)
    if options.episodes is None:
        raise EvaluationError("--episodes is required for a new run", bad_input=True)
    path, _table = read_base_profile(options.profile or "sim")
    return {"seed": 0 if options.seed is None else options.seed, "episodes": options.episodes,
            "profile": str(path.resolve()), "timeout_s": options.timeout_s, "clock": options.clock or "sim",
            "robot": options.robot,
            "created": time.strftime("%Y-%m-%d %H:%M:%S"), "wall_s": 0.0}


def _checkpoint(run_dir: Path, tasks: list[EpisodeTask]) -> Path:
    """The engine's checkpoint for exactly these tasks (another episode count: another file;
    the episodes' own records make a changed run skip what is done anyway)."""
    key = hashlib.sha256(repr(tasks).encode()).hexdigest()[:12]
    return run_dir / f"engine-checkpoint-{key}"


def headline(records: list[dict[str, Any]]) -> list[str]:
    """The few lines a finished run prints."""
    f = summarise(records)
    return [f"{f['episodes']} episodes: success {format_rate(f['success'])}; as expected "
            f"{format_rate(f['as_expected'])}; dropped {format_rate(f['dropped'])}; false stops "
            f"{format_rate(f['false_stop'])}",
            f"failing episodes: {', '.join(str(r['episode']) for r in f['failing']) or 'none'}"]


def run_evaluation(options: RunOptions) -> tuple[Path, list[str]]:
    """Run (or continue) the evaluation of `options`; (report path, headline lines)."""
    from services.studies.engine import run_tasks

    manifest = _manifest(options)
    run_dir = options.out
    run_dir.mkdir(parents=True, exist_ok=True)
    manifest.update(workers=options.workers if options.address is None else f"cluster {options.address}")
    write_json(run_dir / MANIFEST, manifest)
    tasks = [EpisodeTask(str(run_dir.resolve()), k, int(manifest["seed"]), manifest["profile"],
                         float(manifest.get("timeout_s", options.timeout_s)), str(manifest.get("clock", "wall")),
                         manifest.get("robot"))
             for k in range(manifest["episodes"])]
    t0 = time.monotonic()
    try:
        records = run_tasks(run_episode, tasks, address=options.address, workers=options.workers,
                            description="episodes", checkpoint_path=_checkpoint(run_dir, tasks),
                            show_progress=options.show_progress, unit="episode")
    finally:
        manifest["wall_s"] = float(manifest.get("wall_s", 0.0)) + time.monotonic() - t0
        write_json(run_dir / MANIFEST, manifest)
    return write_report(run_dir, manifest, records), headline(records)


def report_again(run_dir: Path) -> tuple[Path, list[str]]:
    """Write the report of the run in `run_dir` from the records it has; (path, headline)."""
    manifest = read_manifest(run_dir)
    records = [r for k in range(int(manifest["episodes"])) if (r := read_record(run_dir, k)) is not None]
    if not records:
        raise EvaluationError(f"{run_dir} has no finished episode yet (no episodes/eNNNN/record.json)")
    return write_report(run_dir, manifest, records), headline(records)
