"""The cross-check's tables: Markdown (summary by group, and every row), CSV, and the
generated region of a docs page.

Values in each quantity's unit (N, s, mm); "none" where a plant has no such event (no slip
onset, never left the pads, never dropped). The in-pad gap is a pairwise quantity: its row
shows the gap as MuJoCo's value and as the difference, and "—" for ours.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path

from robot_sim.contact.config import ContactSimError
from robot_sim.contact.crosscheck.compare import CaseResult, Row

__all__ = ["format_value", "summary_table", "rows_table", "doc_region", "write_csv", "check_region", "rewrite_region",
           "REGION"]

#: Name of the generated region in the docs (`<!-- crosscheck-table:begin ... -->`).
REGION = "crosscheck-table"
_DECIMALS = {"N": 3, "s": 3, "mm": 2, "ms": 1}


def format_value(value: float | bool | None, unit: str) -> str:
    """A value for a table cell: yes/no, none, or the number with the unit's decimals."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if math.isnan(value):
        return "none"
    text = f"{value:.{_DECIMALS.get(unit, 3)}f}"
    return text.lstrip("-") if float(text) == 0.0 else text  # no "-0.000"


def _both_none(row: Row) -> bool:
    return (not isinstance(row.ours, bool) and not isinstance(row.mujoco, bool)
            and math.isnan(row.ours) and math.isnan(row.mujoco))


def _cells(row: Row) -> list[str]:
    ours = "—" if row.quantity == "in_pad_gap_mm" else format_value(row.ours, row.unit)
    diff = row.difference
    verdict = "yes" if row.agree else ("no (expected)" if not row.expect_agree else "**NO**")
    label = f"{row.label} ({row.unit})" if row.unit else row.label
    return [row.scenario, label, ours, format_value(row.mujoco, row.unit),
            format_value(diff, row.unit) if diff is not None and not math.isnan(diff) else "", row.tolerance, verdict]


def rows_table(results: Sequence[CaseResult], skip_both_none: bool = True) -> str:
    """Every row as a Markdown table (scenario, quantity, ours, MuJoCo, difference, tolerance,
    agree), grouped as the cases come; rows with no event on either side left out unless
    `skip_both_none` is False."""
    lines = ["| scenario | quantity | ours | MuJoCo | MuJoCo − ours | tolerance | agree |",
             "|---|---|---:|---:|---:|---|---|"]
    group = None
    for res in results:
        if res.case.group != group:
            group = res.case.group
            lines.append(f"| **{group}** | | | | | | |")
        for row in res.rows:
            if not (skip_both_none and _both_none(row)):
                lines.append("| " + " | ".join(_cells(row)) + " |")
    return "\n".join(lines)


def _worst(rows: Sequence[Row], key: str) -> float:
    diffs = [abs(r.difference) for r in rows if r.quantity == key and r.difference is not None
             and not math.isnan(r.difference)]
    return max(diffs) if diffs else math.nan


def summary_table(results: Sequence[CaseResult]) -> str:
    """One line per group: cases, rows, rows that agree, and the largest differences of the
    main quantities (slip-onset pull N, event times ms, in-pad gap mm)."""
    groups: dict[str, list[CaseResult]] = {}
    for res in results:
        groups.setdefault(res.case.group, []).append(res)
    lines = ["| group | cases | rows | agree | expected | max Δ onset pull (N) | max Δ event time (ms) | "
             "max in-pad gap (mm) |", "|---|---:|---:|---:|---|---:|---:|---:|"]
    for group, items in groups.items():
        rows = [r for res in items for r in res.rows]
        agree = sum(r.agree for r in rows)
        expected = "agree" if items[0].case.expect_agree else "disagree"
        times = [_worst(rows, k) for k in ("onset_time_s", "leave_time_s", "drop_time_s")]
        times = [t for t in times if not math.isnan(t)]
        t_ms = 1e3 * max(times) if times else math.nan
        cells = [format_value(_worst(rows, "onset_pull_n"), "N"), format_value(t_ms, "ms"),
                 format_value(_worst(rows, "in_pad_gap_mm"), "mm")]
        cells = ["–" if c == "none" else c for c in cells]
        lines.append(f"| {group} | {len(items)} | {len(rows)} | {agree} | {expected} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def doc_region(results: Sequence[CaseResult]) -> str:
    """The docs' generated region: the summary by group, then every row in a folded block."""
    n_rows = sum(len(r.rows) for r in results)
    return (summary_table(results) + "\n\n<details><summary>Every row (" + f"{len(results)} cases, {n_rows} rows; "
            "rows where neither plant has the event are left out)</summary>\n\n" + rows_table(results)
            + "\n\n</details>")


def write_csv(results: Sequence[CaseResult], path: str | Path) -> Path:
    """Every row (none rows included) as CSV: group, scenario, quantity, unit, ours, mujoco,
    difference, tolerance, agree, expect_agree, note."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["group", "scenario", "quantity", "unit", "ours", "mujoco", "difference", "tolerance", "agree",
                    "expect_agree", "note"])
        for res in results:
            for r in res.rows:
                w.writerow([r.group, r.scenario, r.quantity, r.unit, r.ours, r.mujoco,
                            "" if r.difference is None else r.difference, r.tolerance, r.agree, r.expect_agree,
                            r.note])
    return path


def _region_bounds(doc: Path, text: str, region: str = REGION) -> tuple[int, int]:
    begin_tag, end_tag = f"<!-- {region}:begin", f"<!-- {region}:end -->"
    start, end = text.find(begin_tag), text.find(end_tag)
    if start < 0 or end < start:
        raise ContactSimError(f"{doc}: no {begin_tag} ... {end_tag} region to rewrite")
    return start, end


def check_region(doc: str | Path, region: str = REGION) -> None:
    """Raise `ContactSimError` unless `doc` is a readable file with the generated region
    `region` (default: the cross-check table's)."""
    doc = Path(doc)
    try:
        text = doc.read_text()
    except OSError as exc:
        raise ContactSimError(f"{doc}: cannot read it ({exc.strerror})") from None
    _region_bounds(doc, text, region)


def rewrite_region(doc: str | Path, body: str, source: str, region: str = REGION) -> Path:
    """Replace the text between `<!-- REGION:begin ... -->` and `<!-- REGION:end -->` in
    `doc` by `body` (the markers stay; `source` names the command that made it, in the begin
    marker); REGION is `region`, by default the cross-check table's (`crosscheck-table`)."""
    doc = Path(doc)
    text = doc.read_text()
    start, end = _region_bounds(doc, text, region)
    begin = f"<!-- {region}:begin (generated by {source}) -->"
    doc.write_text(text[:start] + begin + "\n" + body.strip() + "\n" + text[end:])
    return doc
