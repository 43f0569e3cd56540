"""Command line that writes the motion figures of docs/motion.md: ``python -m services.motion.figures
[OUT_DIR]`` (default docs/img); prints each file written."""

from __future__ import annotations

import sys
from pathlib import Path

from services.motion.figures import make_docs_figures


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else Path("docs/img")
    for path in make_docs_figures(out):
        print(path)
    return 0
