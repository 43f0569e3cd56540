"""The tracker process's settings (`services.tracker.process`): applied, and without effect on
results (OpenCV's labels are the same with one thread as with its pool)."""

from __future__ import annotations

import json
import subprocess
import sys

import cv2
import numpy as np


def test_tune_process_sets_one_opencv_thread():
    code = ("import json, cv2; from services.tracker.process import tune_process; "
            "line = tune_process(); print(json.dumps([line, cv2.getNumThreads()]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    line, threads = json.loads(out.stdout.strip().splitlines()[-1])
    assert threads == 1 and line == "OpenCV threads 1"


def _masks(rng: np.random.Generator, n: int):
    for _ in range(n):
        m = np.zeros((240, 320), np.uint8)
        for _ in range(int(rng.integers(1, 8))):
            r, c = rng.integers(0, 240), rng.integers(0, 320)
            h, w = rng.integers(1, 40, 2)
            m[r:r + h, c:c + w] = 1
        for _ in range(int(rng.integers(0, 20))):  # equal-area blobs: ties broken by label order
            r, c = rng.integers(0, 237), rng.integers(0, 317)
            m[r:r + 3, c:c + 3] = 1
        m[rng.integers(0, 240, 400), rng.integers(0, 320, 400)] = 1
        yield m


def test_labels_are_the_same_with_one_opencv_thread():
    before = cv2.getNumThreads()
    try:
        for m in _masks(np.random.default_rng(0), 300):
            cv2.setNumThreads(2)
            n2, labels2 = cv2.connectedComponents(m, connectivity=8)
            cv2.setNumThreads(1)
            n1, labels1 = cv2.connectedComponents(m, connectivity=8)
            assert n1 == n2 and np.array_equal(labels1, labels2)
    finally:
        cv2.setNumThreads(before)


def test_a_sim_kinect_value_that_is_not_a_table_is_a_one_line_config_error():
    import pytest

    from services.tracker.cli import build_parser
    from services.tracker.config_args import config_from_args
    from services.tracker.errors import TrackerConfigError

    args = build_parser().parse_args(["--sensor", "sim", "--posture", "sitting"])
    assert config_from_args(args, {"sim_kinect": {"seed": 4}}).sim_kinect.posture == "sitting"
    for bad in ("x", 3):
        with pytest.raises(TrackerConfigError, match="sim_kinect must be a table"):
            config_from_args(args, {"sim_kinect": bad})
