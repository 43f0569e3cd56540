"""The camera path's accuracy and cost per frame (docs/camera.md#accuracy-and-cost).

- Accuracy: MediaPipe Pose on the real photographs of `services.tracker.camera.photos`,
  pixel error of each labelled joint against the hand-labelled point.
- Cost per frame on the sample camera's 1024x512 frame, interleaved, ``N_FRAMES`` each:
  baseline ``max_people = 1`` (one model run); the shipped ``max_people = 2`` (one run, then a
  search for a second person that finds nobody); two people in view with ``max_people = 2``
  (two runs); and lifting the receiver into `base` with the depth image. Wall time per frame
  (median, p99) and CPU time per frame (the process's, all threads: TFLite runs its own).

Writes out/bench/camera.json.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

pytest.importorskip("mediapipe", reason="the camera extra is not installed (docs/camera.md#install)")
pytest.importorskip("skimage", reason="the camera extra (scikit-image's photos) is not installed")

from services.tracker.camera import photos  # noqa: E402
from services.tracker.camera.capture import Intrinsics  # noqa: E402
from services.tracker.camera.lift import lift_person  # noqa: E402
from services.tracker.camera.pose2d import PoseEstimator  # noqa: E402
from services.tracker.ros1.calibration import parse_calibration  # noqa: E402
from tests.bench._report import save, summarize, table  # noqa: E402

pytestmark = pytest.mark.bench
N_FRAMES = 60


def _ms(samples_s) -> dict[str, float]:
    return {k: (v * 1e3 if k != "n" else v) for k, v in summarize(samples_s).items()}


def accuracy(est: PoseEstimator) -> dict[str, dict[str, float]]:
    out = {}
    for name, labels in photos.LABELS.items():
        person = est.people(photos.photo(name))[0]
        for joint, label in labels.items():
            got, vis = person.point(joint)
            out[f"{name} {joint}"] = {"error_px": float(np.linalg.norm(got - np.asarray(label))),
                                      "visibility": vis}
    return out


def test_bench_camera_accuracy_latency_and_cpu():
    one, two = PoseEstimator(max_people=1), PoseEstimator(max_people=2)
    acc = accuracy(one)
    errors = np.array([v["error_px"] for v in acc.values()])
    assert np.median(errors) < 25.0 and errors.max() < photos.HALF_BOX_PX, acc

    single, _ = photos.compose(photos.SAMPLE_SCENE)
    pair, _ = photos.compose([("astronaut", "left"), ("cameraman", "right")])
    depth = photos.flat_depth({"right": photos.SAMPLE_DISTANCE_M})
    k = photos.SAMPLE_INTRINSICS_PX
    intr = Intrinsics(k["fx_px"], k["fy_px"], k["cx_px"], k["cy_px"])
    pose = parse_calibration({"position_m": list(photos.SAMPLE_CAMERA_POSITION_M), "rpy_deg": [0, 0, 0]}, "bench")
    cases = {"max_people=1 (baseline)": (one, single), "max_people=2, one person (shipped)": (two, single),
             "max_people=2, two people": (two, pair)}
    wall = {c: [] for c in cases}
    cpu = {c: [] for c in cases}
    lift_s = []
    for _ in range(N_FRAMES):
        for case, (est, frame) in cases.items():
            w0, c0 = time.perf_counter(), time.process_time()
            people = est.people(frame)
            wall[case].append(time.perf_counter() - w0)
            cpu[case].append(time.process_time() - c0)
            assert len(people) == (2 if frame is pair else 1)
            if frame is single:
                receiver = people[0]
        t0 = time.perf_counter()
        p3 = lift_person(receiver, intr, pose, depth, 0.5, 0.36)
        lift_s.append(time.perf_counter() - t0)
        assert p3 is not None
    base = np.median(wall["max_people=1 (baseline)"])
    rows, results = [], {"accuracy": acc, "frames": N_FRAMES}
    for case in cases:
        w, c = _ms(wall[case]), _ms(cpu[case])
        results[case] = {"wall_ms": w, "cpu_ms": c, "wall_ratio_to_baseline": float(np.median(wall[case]) / base)}
        rows.append((case, f"{w['median']:.1f}", f"{w['p99']:.1f}", f"{c['median']:.1f}", f"{c['p99']:.1f}",
                     f"{np.median(wall[case]) / base:.2f}"))
    results["lift_us"] = {key: v * 1e3 if key != "n" else v for key, v in _ms(lift_s).items()}
    print()
    print(table([(name, f"{v['error_px']:.1f}", f"{v['visibility']:.2f}") for name, v in acc.items()],
                ("photo joint", "error px", "visibility")))
    print(f"pixel error over {errors.size} labelled joints: median {np.median(errors):.1f} px, max {errors.max():.1f}")
    print(table(rows, ("case", "wall median ms", "wall p99 ms", "CPU median ms", "CPU p99 ms", "wall / baseline")))
    print(f"lift into base: median {results['lift_us']['median']:.0f} µs")
    print(f"saved {save('camera', results)}")
    one.close()
    two.close()
