"""Benchmark reporting: medians/p99 tables printed and saved as JSON under out/bench/."""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import numpy as np

OUT_DIR = Path(__file__).resolve().parents[2] / "out" / "bench"


def summarize(samples_s: list[float] | np.ndarray) -> dict[str, float]:
    """Median, p90, p99, mean and count of samples in seconds (reported in µs or s)."""
    a = np.asarray(samples_s, dtype=float)
    return {
        "n": int(a.size),
        "median": float(np.median(a)),
        "p90": float(np.percentile(a, 90)),
        "p99": float(np.percentile(a, 99)),
        "mean": float(a.mean()),
        "max": float(a.max()),
    }


def save(name: str, results: dict) -> Path:
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    doc = {"benchmark": name, "when": time.strftime("%Y-%m-%d %H:%M:%S"),
           "machine": {"cpus": __import__("os").cpu_count(), "python": platform.python_version()},
           "results": results}
    path = OUT_DIR / f"{name}.json"
    path.write_text(json.dumps(doc, indent=2))
    return path


def table(rows: list[tuple[str, ...]], header: tuple[str, ...]) -> str:
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    fmt = lambda r: "| " + " | ".join(str(c).ljust(w) for c, w in zip(r, widths, strict=True)) + " |"  # noqa: E731
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    return "\n".join([fmt(header), sep, *map(fmt, rows)])
