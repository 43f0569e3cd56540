"""The CI fault table renderer, on hand-made run records."""

from __future__ import annotations

import json

from tests.faults.report import latency_summary, main, rows


def _doc(run, kind, service, det, stop, violations=()):
    return {"run": run, "faults": [{"kind": kind, "service": service, "phase": "transfer"}],
            "outcome": "protective_stop", "exit_line": f"[launcher] exit 1: {service} | lost",
            "detection_s": {f"{kind} {service}": det}, "stop_s": {f"{kind} {service}": stop} if stop else {},
            "violations": list(violations)}


def test_rows_and_latencies(tmp_path, capsys):
    docs = [_doc("kill-motion-transfer", "kill", "motion", 0.020, 0.100),
            _doc("kill-gripper-transfer", "kill", "gripper", 0.040, None),
            _doc("freeze-bridge-transfer", "freeze", "bridge", 0.210, 0.300, ["arm moved"])]
    table = rows(docs)
    assert table[2].startswith("| freeze-bridge-transfer | freeze bridge @ transfer | protective_stop |")
    assert "exit 1: bridge \\| lost" in table[2] and table[2].endswith("| 210 | 300 | 1 |")
    assert table[3].endswith("| 40 | – | 0 |")
    summary = latency_summary(docs)
    assert "detection after a kill: p50 30 ms, p99 40 ms (n = 2)" in summary  # median of 20 and 40
    assert "stop after a kill: p50 100 ms, p99 100 ms (n = 1)" in summary
    for i, d in enumerate(docs):
        (tmp_path / f"{i}.json").write_text(json.dumps(d))
    assert main([str(tmp_path)]) == 0
    assert "3 runs, 1 invariant violations" in capsys.readouterr().out
    assert main([str(tmp_path / "empty")]) == 2
