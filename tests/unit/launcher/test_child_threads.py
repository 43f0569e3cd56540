"""Every service the launcher starts runs numpy's BLAS and OpenCV without thread pools
(`processes.SINGLE_THREADED_LIBRARIES`): an idle pool's workers cost wakes (OpenCV's poll
with sched_yield after each parallel call), and the services' arrays are small."""

from __future__ import annotations

import os
import sys

from services.launcher.processes import SINGLE_THREADED_LIBRARIES, Child
from services.runtime.outlet import LineOutlet

#: Runs what the tracker runs (OpenCV components, a least-squares fit), then reports.
CHILD = """
import os, numpy as np, cv2
image = (np.random.default_rng(0).random((240, 320)) > 0.5).astype(np.uint8)
for _ in range(20):
    cv2.connectedComponentsWithStats(image)
    np.linalg.lstsq(np.random.rand(400, 3), np.random.rand(400), rcond=None)
print("threads", len(os.listdir("/proc/self/task")), "blas", os.environ.get("OPENBLAS_NUM_THREADS"), flush=True)
"""


def _run_child(tmp_path) -> str:
    path = tmp_path / "child.log"
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    log = LineOutlet(fd, max_lines=64, name="child.log")
    child = Child("numeric", [sys.executable, "-c", CHILD], 8, log=log, verbose=False)
    child.start()
    try:
        assert child.wait(60.0) == 0
    finally:
        child.stop(1.0)
    assert log.close(5.0)  # closes the descriptor too
    return path.read_text()


def test_a_service_runs_numpy_and_opencv_on_its_own_thread(tmp_path, monkeypatch):
    for key in SINGLE_THREADED_LIBRARIES:
        monkeypatch.delenv(key, raising=False)
    assert "threads 1 blas 1" in _run_child(tmp_path)  # no pool thread left behind


def test_a_users_own_thread_setting_is_kept(tmp_path, monkeypatch):
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    assert "blas 2" in _run_child(tmp_path)
