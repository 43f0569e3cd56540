"""`handover-study crosscheck`: our contact plant against MuJoCo, scenario by scenario
(`robot_sim.contact.crosscheck`; method and results in docs/contact.md).

    handover-study crosscheck [--quick] [--img-dir docs/img | --no-images] [--table F] [--csv F] [--doc F]

Runs every case on both plants, prints the summary by group and every unexpected result,
writes the full table (Markdown, CSV), the figures, and (with --doc) the generated region of
a docs page. Exit 0 when every case came out as stated (agreement within tolerance, or a
known difference that shows), 1 otherwise.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

DESCRIPTION = "Cross-check the contact plant against MuJoCo: slip onset, slides, catches, drops."
_SOURCE = "handover-study crosscheck --doc docs/contact.md"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The cross-check's flags."""
    parser.add_argument("--quick", action="store_true", help="only the few CI cases (about a second)")
    parser.add_argument("--img-dir", type=Path, default=Path("docs/img"), help="where PNGs go (default docs/img)")
    parser.add_argument("--no-images", action="store_true", help="skip the figures")
    parser.add_argument("--table", type=Path, default=Path("out/crosscheck/table.md"), help="Markdown table output")
    parser.add_argument("--csv", type=Path, default=Path("out/crosscheck/rows.csv"), help="CSV of every row")
    parser.add_argument("--doc", type=Path, help="rewrite this page's crosscheck-table region (e.g. docs/contact.md)")


#: (groups, figure, what the panels show; None = the slip-onset scatter).
_FIGURE_SETS = ((("slip onset",), "onset", None), (("slide", "catch"), "slide", "distance"),
                (("receiver",), "receiver", "position"), (("μ_k < μ_s (ours)",), "difference", "position"))


def _figures(results, img_dir: Path) -> list[Path]:
    from robot_sim.contact.crosscheck.plots import FIGURES, plot_onset, plot_traces

    made = []
    for groups, name, what in _FIGURE_SETS:
        items = [r for r in results if r.case.group in groups]
        if items:
            path = img_dir / FIGURES[name]
            made.append(plot_onset(items, path) if what is None
                        else plot_traces(items, path, what, columns=min(4, len(items))))
    return made


def run(args: argparse.Namespace) -> int:
    """Run the cross-check and write its outputs; exit 1 if a case did not come out as stated."""
    from robot_sim.contact.config import ContactSimError
    from robot_sim.contact.crosscheck.catalogue import all_cases, quick_cases
    from robot_sim.contact.crosscheck.compare import compare_all, problems
    from robot_sim.contact.crosscheck.report import (
        check_region,
        doc_region,
        rewrite_region,
        rows_table,
        summary_table,
        write_csv,
    )

    if args.doc is not None:
        try:
            check_region(args.doc)
        except ContactSimError as exc:
            print(f"handover-study crosscheck: error: {exc}", file=sys.stderr)
            return 2
    cases = quick_cases() if args.quick else all_cases()
    start = time.perf_counter()
    results = compare_all(cases, keep_runs=lambda case: case.group != "slip onset")
    elapsed = time.perf_counter() - start
    summary = summary_table(results)
    print(summary)
    print(f"{len(cases)} cases on both plants in {elapsed:.1f} s")
    if not args.quick:
        from robot_sim.contact.crosscheck.diagnostics import diagnostics_lines

        for line in diagnostics_lines():
            print(line)
    args.table.parent.mkdir(parents=True, exist_ok=True)
    args.table.write_text(summary + "\n\n" + rows_table(results, skip_both_none=False) + "\n", encoding="utf-8")
    written = [args.table, write_csv(results, args.csv)]
    if not args.no_images:
        args.img_dir.mkdir(parents=True, exist_ok=True)
        written += _figures(results, args.img_dir)
    if args.doc is not None:
        written.append(rewrite_region(args.doc, doc_region(results), _SOURCE))
    for path in written:
        print(f"wrote {path}")
    found = problems(results)
    for line in found:
        print(f"UNEXPECTED: {line}", file=sys.stderr)
    return 1 if found else 0
