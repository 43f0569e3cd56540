"""The full fault matrix (each service × phase × fault, 10 runs per cell): hours, on demand.

    python -m pytest tests/faults/test_fault_matrix.py -m long -s
    FAULT_MATRIX_ARGS="--runs 1 --services motion --phases transfer" python -m pytest ... -m long

It drives `tests.faults.matrix` (resumable: cells already in docs/data/faults/matrix.json are
skipped) and fails if any run broke an invariant.
"""

from __future__ import annotations

import json
import os
import shlex

import pytest

from tests.faults import matrix

pytestmark = [pytest.mark.long, pytest.mark.integration, pytest.mark.timeout(0)]


def test_full_fault_matrix_keeps_every_invariant():
    args = shlex.split(os.environ.get("FAULT_MATRIX_ARGS", "--runs 10"))
    assert matrix.main(args) == 0
    results = json.loads((matrix.OUT / "matrix.json").read_text())
    broken = {k: [r["violations"] for r in c["runs"] if r["violations"]] for k, c in results.items()}
    broken = {k: v for k, v in broken.items() if v}
    assert not broken, json.dumps(broken, indent=1)[:5000]
