"""Colour frames (and aligned depth) from OpenCV or a RealSense.

- `OpenCvFrames`: a device index (``"0"``), a video file, or a folder of images sorted by name;
- `DepthFolder`: 16-bit PNG depth images in millimetres, the i-th aligned with the i-th colour frame;
- `RealSenseFrames`: colour and depth aligned to it, from ``pyrealsense2`` (optional package).

Every source's `read()` returns the next `Frame`, None while a live camera has nothing new,
and raises `SourceEnded` at the end of a file or folder (unless looped). Frames carry the
source's own time (the video's position, the folder's index over the rate, a live camera's
arrival), which orders them; `FrameOrder` drops a frame that is not newer than the last one.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from services.tracker.errors import CameraError

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".ppm", ".tif", ".tiff")


class SourceEnded(Exception):
    """A video file or image folder has no more frames."""


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of the colour image, px."""

    fx: float
    fy: float
    cx: float
    cy: float


@dataclass(frozen=True)
class Frame:
    """One colour frame.

    Attributes:
        index: its number in the source (0, 1, …; a looped source goes on counting).
        rgb: (H, W, 3) uint8, RGB.
        stamp_s: the source's time of the frame, s (orders frames; not comparable to ours).
        depth_mm: (H, W) uint16 depth aligned with `rgb`, mm (0: no reading), or None.
    """

    index: int
    rgb: np.ndarray
    stamp_s: float
    depth_mm: np.ndarray | None = None


def _images(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)


class OpenCvFrames:
    """Frames from ``cv2.VideoCapture`` (device index or video file) or an image folder.

    Args:
        spec: ``"0"``…``"9"`` (a device), a video file or a folder.
        rate_hz: a folder's frames are ``1 / rate_hz`` apart in source time.
        loop: start a file or folder over at its end.

    Raises:
        CameraError: the device cannot be opened, the file or folder does not exist or holds
            no image.
    """

    def __init__(self, spec: str, rate_hz: float, loop: bool) -> None:
        self.spec, self.rate_hz, self.loop = spec, rate_hz, loop
        self.live = spec.isdigit()
        self._files: list[Path] = []
        self._cap: cv2.VideoCapture | None = None
        self._next = 0
        self._offset_s = 0.0  # source time added per loop
        self.read_failures = 0
        path = Path(spec)
        if self.live:
            quiet = cv2.utils.logging.getLogLevel()
            cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)  # our error says it in one line
            try:
                self._cap = cv2.VideoCapture(int(spec))
            finally:
                cv2.utils.logging.setLogLevel(quiet)
            if not self._cap.isOpened():
                raise CameraError(f"camera {spec} cannot be opened: is a camera connected (ls /dev/video*), "
                                  "and is it free (no other program using it)?")
        elif path.is_dir():
            self._files = _images(path)
            if not self._files:
                raise CameraError(f"image folder {path} holds no image ({', '.join(IMAGE_SUFFIXES)})")
        elif path.is_file():
            self._open_video()
        else:
            raise CameraError(f"camera input {spec} is neither a device index, a video file nor an image folder")

    def _open_video(self) -> None:
        self._cap = cv2.VideoCapture(self.spec)
        if not self._cap.isOpened():
            raise CameraError(f"video file {self.spec} cannot be opened by OpenCV (not a video, or its codec "
                              "is missing: MJPG or PNG in an .avi always work)")

    def read(self) -> Frame | None:
        """The next frame (None: a live camera gave nothing this time). Raises `SourceEnded`."""
        if self._files:
            return self._read_file()
        assert self._cap is not None
        ok, bgr = self._cap.read()
        if not ok or bgr is None:
            if self.live:
                self.read_failures += 1
                return None
            if not self.loop:
                raise SourceEnded(self.spec)
            self._cap.release()
            self._open_video()
            self._offset_s += (self._next + 1) / self.rate_hz
            return None
        index = self._next
        self._next += 1
        if self.live:
            stamp = time.monotonic()
        else:
            stamp = self._offset_s + float(self._cap.get(cv2.CAP_PROP_POS_MSEC)) / 1000.0
        return Frame(index, cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), stamp)

    def _read_file(self) -> Frame:
        n = len(self._files)
        if self._next >= n and not self.loop:
            raise SourceEnded(self.spec)
        index = self._next
        path = self._files[index % n]
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if bgr is None:
            raise CameraError(f"image {path} cannot be read (not an image, or damaged)")
        self._next += 1
        return Frame(index, cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), index / self.rate_hz)

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()


class DepthFolder:
    """Aligned depth images: 16-bit PNG, mm, one per colour frame in name order.

    Raises:
        CameraError: the folder does not exist or holds no PNG.
    """

    def __init__(self, folder: Path) -> None:
        if not folder.is_dir():
            raise CameraError(f"depth folder {folder} does not exist")
        self.files = sorted(p for p in folder.iterdir() if p.suffix.lower() == ".png")
        if not self.files:
            raise CameraError(f"depth folder {folder} holds no .png (16-bit, millimetres)")

    def get(self, index: int, shape: tuple[int, int]) -> np.ndarray:
        """The depth image (H, W) uint16 mm of colour frame `index` (looped over the folder).

        Raises:
            CameraError: not a 16-bit single-channel image, or not the colour frame's size.
        """
        path = self.files[index % len(self.files)]
        depth = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if depth is None or depth.dtype != np.uint16 or depth.ndim != 2:
            raise CameraError(f"depth image {path} is not a 16-bit single-channel PNG (millimetres)")
        if depth.shape != shape:
            raise CameraError(f"depth image {path} is {depth.shape[1]}x{depth.shape[0]}, the colour frame "
                              f"{shape[1]}x{shape[0]}: depth must be aligned to the colour image")
        return depth


class RealSenseFrames:
    """Colour and depth aligned to it from an Intel RealSense (``pip install pyrealsense2``).

    Raises:
        CameraError: pyrealsense2 is missing, or no RealSense is connected.
    """

    def __init__(self, width: int = 640, height: int = 480, fps: int = 30) -> None:
        try:
            import pyrealsense2 as rs  # type: ignore[import-not-found]
        except ImportError:
            raise CameraError("camera.input = \"realsense\" needs pyrealsense2: pip install pyrealsense2 "
                              "(docs/camera.md#realsense)") from None
        self.rs, self.live, self._next = rs, True, 0
        self.read_failures = 0
        config = rs.config()
        config.enable_stream(rs.stream.color, width, height, rs.format.rgb8, fps)
        config.enable_stream(rs.stream.depth, width, height, rs.format.z16, fps)
        self.pipeline = rs.pipeline()
        try:
            profile = self.pipeline.start(config)
        except RuntimeError as exc:
            raise CameraError(f"no RealSense could be started ({exc}): is it connected to a USB 3 port?") from None
        self.depth_scale_mm = profile.get_device().first_depth_sensor().get_depth_scale() * 1000.0
        self.align = rs.align(rs.stream.color)
        k = profile.get_stream(rs.stream.color).as_video_stream_profile().get_intrinsics()
        self.intrinsics = Intrinsics(k.fx, k.fy, k.ppx, k.ppy)

    def read(self) -> Frame | None:
        ok, frames = self.pipeline.try_wait_for_frames(100)
        if not ok:
            self.read_failures += 1
            return None
        frames = self.align.process(frames)
        colour, depth = frames.get_color_frame(), frames.get_depth_frame()
        if not colour or not depth:
            return None
        rgb = np.asanyarray(colour.get_data()).copy()
        depth_mm = np.asanyarray(depth.get_data()).astype(np.float32) * self.depth_scale_mm
        index = self._next
        self._next += 1
        return Frame(index, rgb, colour.get_timestamp() / 1000.0, np.clip(depth_mm, 0, 65535).astype(np.uint16))

    def close(self) -> None:
        self.pipeline.stop()


class FrameOrder:
    """Drops frames whose source time is not after the last kept one (counted)."""

    def __init__(self) -> None:
        self.last_s = -float("inf")
        self.dropped = 0

    def keep(self, frame: Frame) -> bool:
        if frame.stamp_s <= self.last_s:
            self.dropped += 1
            return False
        self.last_s = frame.stamp_s
        return True
