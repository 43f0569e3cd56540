"""Process-wide settings of the tracker service, applied once by `services.tracker.node.run_node`
(the service's own process only; library use and the tests keep the defaults).

OpenCV's thread pool: one thread (`cv2.setNumThreads(1)`). The object detection's labelling
(`cv2.connectedComponents`) ran split over the pool's 2 threads on the small candidate image;
the second thread then spun waiting for more work (~0.6 ms of CPU per detection, ~0.006 core
at 10 Hz). One thread gives the same labels (tested: `tests/unit/tracker/test_process.py`).
`handover-up` also starts every service with ``OPENCV_FOR_THREADS_NUM=1``
(`services.launcher.processes.SINGLE_THREADED_LIBRARIES`); this covers a tracker started on
its own. The allocator's settings that keep a detection's temporaries in the heap are every
service's (`services.runtime.allocator`, applied by `run_main`).
"""

from __future__ import annotations

import cv2


def tune_process() -> str:
    """Apply the tracker process's settings (see the module docstring); returns a log line."""
    cv2.setNumThreads(1)
    return f"OpenCV threads {cv2.getNumThreads()}"
