"""The camera's own thread: frames in, people in `base` out (the tracker's tick never waits
for the body-pose model, which takes tens of milliseconds a frame).

`open_rig` opens everything before the tracker joins the bus (calibration, camera, depth,
model), so a missing camera, file or package stops the start with one line.
`CameraWorker` then reads a frame at most every ``1 / rate_hz``, drops frames out of order,
runs the model, lifts each person into `base` and queues a `CameraResult` (the newest two
are kept; older ones are dropped and counted).
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from services.runtime.logs import RateLimitedLog, kv
from services.tracker.camera.capture import (DepthFolder, Frame, FrameOrder, Intrinsics, OpenCvFrames,
                                             RealSenseFrames, SourceEnded)
from services.tracker.camera.config import CameraConfig
from services.tracker.camera.lift import Person3D, lift_person
from services.tracker.camera.pose2d import PoseEstimator
from services.tracker.errors import CameraError, TrackerConfigError
from services.tracker.ros1.calibration import CameraPose, load_calibration

log = logging.getLogger("tracker")


@dataclass
class Rig:
    """An opened camera: frames, depth, intrinsics, calibration and the model."""

    config: CameraConfig
    frames: OpenCvFrames | RealSenseFrames
    depth: DepthFolder | None
    intrinsics: Intrinsics
    pose: CameraPose
    estimator: PoseEstimator

    def close(self) -> None:
        self.frames.close()
        self.estimator.close()


def open_rig(config: CameraConfig, folder: Path) -> Rig:
    """Open the camera of `config`; relative paths are relative to `folder` (the profile's).

    Raises:
        TrackerConfigError: the set-up is incomplete (`CameraConfig.problems`).
        CalibrationError: the calibration file is missing or invalid.
        CameraError: no camera, no such file or folder, no MediaPipe.
    """
    problems = config.problems()
    if problems:
        raise TrackerConfigError(f"invalid tracker config: {problems[0]}")

    def resolve(name: str) -> Path:
        path = Path(name).expanduser()
        return path if path.is_absolute() else folder / path

    pose = load_calibration(resolve(config.calibration_file), config.camera_frame)
    estimator = PoseEstimator(config.max_people, config.min_visibility)  # before the camera: fails fast
    frames: OpenCvFrames | RealSenseFrames
    if config.input == "realsense":
        frames = RealSenseFrames()
        intrinsics = frames.intrinsics
    else:
        spec = config.input if config.input.isdigit() else str(resolve(config.input))
        frames = OpenCvFrames(spec, config.rate_hz, config.loop)
        intrinsics = Intrinsics(config.fx_px, config.fy_px, config.cx_px, config.cy_px)
    depth = None if config.depth in ("none", "realsense") else DepthFolder(resolve(config.depth))
    return Rig(config, frames, depth, intrinsics, pose, estimator)


@dataclass(frozen=True)
class CameraResult:
    """One processed frame.

    Attributes:
        frame: the frame (its depth filled in when there is one).
        rx_s: when it was read (local monotonic s): the skeleton's age counts from here.
        people: everyone found, in `base`.
        found_2d: people the model found (some may lack a distance, so not in `people`).
        infer_s: the model's time on this frame, s.
    """

    frame: Frame
    rx_s: float
    people: list[Person3D]
    found_2d: int
    infer_s: float


@dataclass
class WorkerStats:
    frames: int = 0
    out_of_order: int = 0
    skipped: int = 0
    dropped: int = 0
    failed: int = 0
    infer_s: list[float] = field(default_factory=list)


class CameraWorker(threading.Thread):
    """Reads and processes frames until `stop()` or the end of the source (see the module docstring)."""

    def __init__(self, rig: Rig) -> None:
        super().__init__(name="camera", daemon=True)
        self.rig = rig
        self.stats = WorkerStats()
        self.ended = threading.Event()
        self.last_frame_s: float | None = None
        self._halt = threading.Event()
        self._lock = threading.Lock()
        self._results: deque[CameraResult] = deque()
        self._order = FrameOrder()
        self._warn = RateLimitedLog(log, 5.0)

    def stop(self) -> None:
        self._halt.set()

    def drain(self) -> list[CameraResult]:
        with self._lock:
            out = list(self._results)
            self._results.clear()
        return out

    def run(self) -> None:
        period = 1.0 / self.rig.config.rate_hz
        next_s = time.monotonic()
        try:
            while not self._halt.is_set():
                now = time.monotonic()
                if now < next_s and not getattr(self.rig.frames, "live", False):
                    self._halt.wait(next_s - now)  # a file or folder: read at the rate
                    continue
                frame = self.rig.frames.read()
                if frame is None:
                    self._halt.wait(0.005)
                    continue
                rx_s = time.monotonic()
                if rx_s < next_s:  # a live camera faster than the rate: skip this one
                    self.stats.skipped += 1
                    continue
                next_s = max(next_s + period, rx_s - period)
                self._process(frame, rx_s)
        except SourceEnded:
            log.info("camera input ended", extra=kv(frames=self.stats.frames))
        except Exception as exc:  # noqa: BLE001 - the thread must report, not die silently
            log.error("camera stopped: %s", exc)
        finally:
            self.ended.set()

    def _process(self, frame: Frame, rx_s: float) -> None:
        if not self._order.keep(frame):
            self.stats.out_of_order += 1
            self._warn.warning("order", f"frame {frame.index} is not newer than the previous one: dropped",
                               out_of_order=self.stats.out_of_order)
            return
        rig = self.rig
        try:
            if rig.depth is not None:
                frame = Frame(frame.index, frame.rgb, frame.stamp_s, rig.depth.get(frame.index, frame.rgb.shape[:2]))
            t0 = time.perf_counter()
            found = rig.estimator.people(frame.rgb)
            infer_s = time.perf_counter() - t0
        except (CameraError, ValueError) as exc:
            self.stats.failed += 1
            self._warn.warning("frame", f"frame {frame.index} skipped: {exc}", failed=self.stats.failed)
            return
        people = [p for p in (lift_person(f, rig.intrinsics, rig.pose, frame.depth_mm, rig.config.min_visibility,
                                          rig.config.shoulder_width_m) for f in found) if p is not None]
        self.stats.frames += 1
        if len(self.stats.infer_s) < 100000:
            self.stats.infer_s.append(infer_s)
        with self._lock:
            self._results.append(CameraResult(frame, rx_s, people, len(found), infer_s))
            while len(self._results) > 2:
                self._results.popleft()
                self.stats.dropped += 1
        self.last_frame_s = rx_s

    def summary(self) -> dict[str, float]:
        """Counts and the model's median time per frame (ms), for the log at the end."""
        s = self.stats
        median_ms = float(np.median(s.infer_s) * 1000.0) if s.infer_s else 0.0
        return {"frames": s.frames, "out_of_order": s.out_of_order, "skipped": s.skipped, "dropped": s.dropped,
                "failed": s.failed, "infer_median_ms": round(median_ms, 1)}
