"""The evaluation report: ``report.md`` (tables with 95 % intervals, the failing episodes and
how to replay each one), ``summary.json`` (the same figures, machine-readable) and the plots,
in ``<run>/report/``."""

from __future__ import annotations

import dataclasses
import json
import shlex
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from services.studies.evaluation.population import NOT_VARIED, VARIABLES
from services.studies.evaluation.stats import Quantile, Rate, format_quantile, format_rate
from services.studies.evaluation.summary import CRITERIA, QUANTITIES, summarise

CRITERION_TEXT = {
    "plan": "a transfer goal (the reach to the DJT point) was reached by the motion service",
    "reach": "the receiver's true hand came within 6 cm of the object while the robot held it (absent: n/a)",
    "stability": "never dropped, and ≤ 1 cm slip in the pads while the robot alone carried it",
    "affordance": "not defined: the simulated object has no parts to leave free for the receiver",
    "safe": "arm ≤ 0.25 m/s within 0.3 m of the true hand (whole episode), grip ≤ 140 N, never dropped",
}


def replay_command(run_dir: Path, episode: int) -> str:
    """The one command that runs an episode again and points to its new recording."""
    return f"handover-eval replay --run {shlex.quote(str(run_dir))} --episode {episode}"


def _json_ready(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.asdict(value)
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_json_ready(v) for v in value]
    return value


def _rate_table(title: str, groups: dict[str, dict[str, Rate]]) -> list[str]:
    lines = [f"| {title} | success | as expected | dropped |", "|---|---|---|---|"]
    lines += [f"| {name} | {format_rate(r['success'])} | {format_rate(r['as_expected'])} | "
              f"{format_rate(r['dropped'])} |" for name, r in groups.items()]
    return lines + [""]


def _quantity_table(quantities: dict[str, dict[str, Quantile]]) -> list[str]:
    lines = ["| quantity | unit | episodes | median (95 % CI) | p95 (95 % CI) |", "|---|---|---|---|---|"]
    for field, label, unit, scale, which in QUANTITIES:
        q = quantities[field]
        lines.append(f"| {label} | {unit} | {which}, n = {q['median'].n} | {format_quantile(q['median'], scale)} | "
                     f"{format_quantile(q['p95'], scale)} |")
    return lines + [""]


def _failing(run_dir: Path, failing: Sequence[dict[str, Any]]) -> list[str]:
    if not failing:
        return ["None: every episode went as expected.", ""]
    lines = ["| episode | seed | behaviour | posture | height | outcome | why | replay |",
             "|---|---|---|---|---|---|---|---|"]
    for r in failing:
        why = str(r.get("reason", "")).replace("|", "/")[:160]
        if r.get("protective_stops"):
            why = "protective stop: " + "; ".join(r["protective_stops"])[:160]
        lines.append(f"| {r['episode']} | {r['seed']} | {r['behaviour']} | {r['posture']} | {r['height_m']:.2f} m | "
                     f"{r['outcome']}{' (dropped)' if r.get('dropped') else ''} | {why} | "
                     f"`{replay_command(run_dir, r['episode'])}` |")
    return lines + ["", "Each replay runs the episode's stack again (its profile, its seed) into "
                    "`<run>/replays/` and prints the new recording and the `rerun` command that opens it; the "
                    "original recording is in the record (`episodes/eNNNN/`).", ""]


def render(run_dir: Path, manifest: dict[str, Any], figures: dict[str, Any], plots: Sequence[str]) -> str:
    """The report's markdown."""
    f = figures
    lines = [f"# Evaluation: {f['episodes']} episodes", "",
             f"Run `{run_dir}`, population seed {manifest['seed']}, profile `{manifest['profile']}`"
             + (f", arm {manifest['robot']} (`--robot`)" if manifest.get("robot") else "") + ", "
             f"wall time {manifest.get('wall_s', 0.0) / 60:.1f} min with {manifest.get('workers', '?')} worker(s). "
             "Intervals: 95 % (Wilson for rates, order statistics for medians and p95).", "",
             "## Headline", "",
             f"- success (released into the receiver's hand, never dropped): {format_rate(f['success'])}",
             f"- as expected for the receiver's behaviour: {format_rate(f['as_expected'])}",
             f"- dropped: {format_rate(f['dropped'])}",
             f"- episodes with a false protective stop: {format_rate(f['false_stop'])}"
             + (f" ({'; '.join(f'{k}: {v}' for k, v in f['stop_reasons'].items())})" if f["stop_reasons"] else ""),
             f"- outcomes: {', '.join(f'{k} {v}' for k, v in f['outcomes'].items())}", "",
             "## Outcome by behaviour, posture and height", ""]
    lines += _rate_table("behaviour", f["by_behaviour"]) + _rate_table("posture", f["by_posture"])
    lines += _rate_table("height", f["by_height"])
    lines += ["## Times, distances, speeds and forces", ""] + _quantity_table(f["quantities"])
    lines += ["## R2HandoverSim's five criteria", "", "| criterion | how | rate |", "|---|---|---|"]
    lines += [f"| {c} | {CRITERION_TEXT[c]} | {format_rate(f['criteria'][c])} |" for c in CRITERIA] + [""]
    lines += ["## Failing episodes", ""] + _failing(run_dir, f["failing"])
    if plots:
        lines += ["## Plots", ""] + [f"![{Path(p).stem}]({Path(p).name})" for p in plots] + [""]
    lines += ["## Population", "", "| variable | unit | distribution | source |", "|---|---|---|---|"]
    lines += [f"| {v.name} | {v.unit} | {v.distribution} | {v.source} |" for v in VARIABLES]
    lines += ["", "Not varied (the simulation cannot set them today):", ""]
    lines += [f"- {what}: {why}" for what, why in NOT_VARIED] + [""]
    return "\n".join(lines)


def write_report(run_dir: Path, manifest: dict[str, Any], records: Sequence[dict[str, Any]]) -> Path:
    """Write ``report.md``, ``summary.json`` and the plots into ``<run_dir>/report/``; the
    report's path."""
    from services.studies.evaluation.plots import draw_plots

    folder = run_dir / "report"
    folder.mkdir(parents=True, exist_ok=True)
    figures = summarise(records)
    plots = draw_plots(records, folder)
    (folder / "summary.json").write_text(json.dumps(_json_ready({**figures, "failing": [
        r["episode"] for r in figures["failing"]]}), indent=1))
    path = folder / "report.md"
    path.write_text(render(run_dir, manifest, figures, plots))
    return path
