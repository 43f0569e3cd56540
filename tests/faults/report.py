"""The CI fault table from the JSON each fault-injection run leaves (`<DIR>/*.json`).

    python -m tests.faults.report [DIR]        # default: $HANDOVER_FAULT_REPORT_DIR, else
                                               # handover-faults-ci in the temporary folder

The runs write there, not into the checkout: the test suite leaves the checkout unchanged.

Prints one Markdown row per run (faults, outcome, launcher exit line, detection and stop in
ms from the injection, invariant violations) and the p50/p99 of detection and stop after a
kill and after a freeze.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

#: Where `tests/faults/test_fault_injection.py` leaves one JSON per run.
DEFAULT_DIR = Path(os.environ.get("HANDOVER_FAULT_REPORT_DIR") or Path(tempfile.gettempdir()) / "handover-faults-ci")


def _ms(values: list[float]) -> str:
    return ", ".join(f"{v * 1000:.0f}" for v in values) if values else "–"


def rows(docs: list[dict]) -> list[str]:
    out = ["| run | faults | outcome | launcher exit line | detection ms | stop ms | violations |",
           "|---|---|---|---|---|---|---|"]
    for d in sorted(docs, key=lambda d: d["run"]):
        faults = "; ".join(f"{f['kind']} {f['service']}" + (f" {f['topic']}" if f.get("topic") else "")
                           + f" @ {f['phase']}" for f in d["faults"])
        exit_line = d.get("exit_line", "").replace("[launcher] ", "").replace("|", "\\|")
        if len(exit_line) > 110:
            exit_line = exit_line[:107] + "…"
        out.append(f"| {d['run']} | {faults} | {d.get('outcome')} | `{exit_line}` | "
                   f"{_ms(list(d.get('detection_s', {}).values()))} | {_ms(list(d.get('stop_s', {}).values()))} | "
                   f"{len(d.get('violations', []))} |")
    return out


def latency_summary(docs: list[dict]) -> list[str]:
    lines = []
    for kind in ("kill", "freeze"):
        for what in ("detection_s", "stop_s"):
            vals = [v for d in docs if d["run"].startswith(f"{kind}-") for v in d.get(what, {}).values()]
            if vals:
                p50, p99 = np.percentile(vals, [50, 99]) * 1000
                lines.append(f"{what[:-2]} after a {kind}: p50 {p50:.0f} ms, p99 {p99:.0f} ms (n = {len(vals)})")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.faults.report", description=__doc__.splitlines()[0])
    parser.add_argument("directory", nargs="?", type=Path, default=DEFAULT_DIR)
    args = parser.parse_args(argv)
    docs = [json.loads(p.read_text()) for p in sorted(args.directory.glob("*.json"))]
    if not docs:
        print(f"report: no fault-run JSON in {args.directory} (run tests/faults/test_fault_injection.py first)",
              file=sys.stderr)
        return 2
    print("\n".join(rows(docs)))
    print()
    print("\n".join(latency_summary(docs)))
    violations = sum(len(d.get("violations", [])) for d in docs)
    print(f"{len(docs)} runs, {violations} invariant violations")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
