"""Run one episode of an evaluation again: its own profile (the draw and its seed), a new
folder ``<run>/replays/eNNNN-<time>/``, its outcome beside the original's, and the command
that opens the new recording.

The stack runs on the run's clock (its manifest's): on the simulation clock the replay is the
same episode step for step; on the wall clock the seed fixes the receiver, the object and the
noise but not the services' timing, so a replay can differ in details (and, near a threshold,
in its outcome). The original recording stays in ``episodes/eNNNN/``.
"""

from __future__ import annotations

import time
from pathlib import Path

from services.studies.evaluation.errors import EvaluationError
from services.studies.evaluation.population import draw_episode
from services.studies.evaluation.run import read_manifest
from services.studies.evaluation.runner import episode_dir, planner_config, read_record, run_and_record, write_json
from services.studies.evaluation.episode_profile import read_base_profile


def _describe(record: dict) -> str:
    dropped = ", dropped" if record.get("dropped") else ""
    stops = f", protective stop: {'; '.join(record['protective_stops'])}" if record.get("protective_stops") else ""
    return f"{record.get('outcome')}{dropped}{stops} ({record.get('reason', '')})"


def replay(run_dir: Path, episode: int, timeout_s: float) -> tuple[list[str], Path]:
    """Run episode `episode` of the run in `run_dir` again; (lines to print, new recording).

    Raises:
        EvaluationError: (bad input) no such run or episode.
    """
    manifest = read_manifest(run_dir)
    if not 0 <= episode < int(manifest["episodes"]):
        raise EvaluationError(f"--episode {episode}: the run has episodes 0–{int(manifest['episodes']) - 1}",
                              bad_input=True)
    profile = episode_dir(run_dir, episode) / "profile.toml"
    if not profile.is_file():
        raise EvaluationError(f"--episode {episode} has not run yet ({profile} is missing): continue the run with "
                              f"handover-eval run --out {run_dir} --resume", bad_input=True)
    draw = draw_episode(int(manifest["seed"]), episode)
    _path, base = read_base_profile(manifest["profile"])
    folder = run_dir / "replays" / f"e{episode:04d}-{time.strftime('%Y%m%d-%H%M%S')}"
    folder.mkdir(parents=True, exist_ok=True)
    record = run_and_record(folder, profile, draw, planner_config(base), timeout_s, str(manifest.get("clock", "wall")))
    write_json(folder / "record.json", record)
    original = read_record(run_dir, episode)
    recording = Path(record["recording"])
    lines = [f"episode {episode} (seed {draw.sim_seed}: {draw.behaviour} receiver, {draw.posture}, "
             f"{draw.height_m:.2f} m, object {draw.object_mass_kg:.3f} kg)",
             f"  replay:   {_describe(record)}"]
    if original is not None:
        lines.append(f"  original: {_describe(original)}")
    lines += [f"recording: {recording}  (open it with: rerun {recording})",
              f"logs and console: {folder}/"]
    return lines, recording
