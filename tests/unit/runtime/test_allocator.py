"""keep_freed_memory: a service's per-frame temporaries reuse the same pages instead of being
mapped, faulted in and unmapped frame after frame (`services.runtime.allocator`)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from services.runtime.allocator import MMAP_THRESHOLD_BYTES

# Frames whose temporaries are a little larger each time (a hand's window of points growing
# as it comes closer): each is above glibc's adaptive threshold, so by default each is mapped
# afresh and every one of its pages faulted in.
_FRAMES = """
import json, resource, sys
import numpy as np
if sys.argv[1] == "keep":
    from services.runtime.allocator import keep_freed_memory
    assert keep_freed_memory()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for k in range(300):
    window = np.ones(200_000 + 4096 * k, np.uint8)  # written through: every page touched
    del window
print(json.dumps({"faults_per_frame": (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 300}))
"""


def _faults_per_frame(mode: str) -> float:
    out = subprocess.run([sys.executable, "-c", _FRAMES, mode], capture_output=True, text=True, timeout=120,
                         cwd=Path(__file__).resolve().parents[3])
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)["faults_per_frame"]


def test_frame_temporaries_stop_faulting_in_fresh_pages():
    default = _faults_per_frame("default")
    kept = _faults_per_frame("keep")
    assert default > 100, default  # ~200 kB to 1.4 MB of fresh zero pages a frame
    assert kept < 0.05 * default, (kept, default)


def test_the_largest_depth_frame_temporaries_are_under_the_mmap_threshold():
    # A 640×480 float64 xyz cloud (the largest a Kinect v1 mode gives) still comes from the heap.
    assert 640 * 480 * 3 * 8 <= MMAP_THRESHOLD_BYTES
