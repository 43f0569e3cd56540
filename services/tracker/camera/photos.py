"""Real photographs of people shipped by registry packages, their hand-labelled joints, and a
sample camera input built from them (the camera path's tests, benchmark and `deploy/camera.toml`).

Photos (no download: the files are inside the wheels):

- ``astronaut``: scikit-image's ``data.astronaut()``, Eileen Collins, upper body, 512×512;
- ``cameraman``: scikit-image's ``data.camera()``, a man in profile behind a camera, 512×512 grey;
- ``hopper``: matplotlib's sample ``grace_hopper.jpg``, head and shoulders, 512×600;
- ``cat``: scikit-image's ``data.chelsea()`` (no person); ``coffee``: ``data.coffee()`` (no person).

`LABELS`: joints labelled by eye on a 20-px grid of each photo (pixels, x right, y down);
`HALF_BOX_PX` is the half edge of the box a detection must fall in. Joints hidden in the
photo (the astronaut's left elbow and wrist behind the helmet) are not labelled.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from services.tracker.errors import CameraError

#: Hand-labelled joints per photo, px (photo's own size).
LABELS: dict[str, dict[str, tuple[float, float]]] = {
    "astronaut": {"right_shoulder": (100, 245), "left_shoulder": (312, 265), "right_elbow": (55, 418),
                  "right_wrist": (165, 485)},
    "cameraman": {"right_shoulder": (105, 180), "right_elbow": (138, 300)},
    "hopper": {"right_shoulder": (95, 420), "left_shoulder": (452, 425)},
}
#: Half edge of the hand-checked box around a label, px: about a fifth of the shoulder width.
HALF_BOX_PX = 40.0
PEOPLE = {"astronaut": 1, "cameraman": 1, "hopper": 1, "cat": 0, "coffee": 0}


def photo(name: str) -> np.ndarray:
    """The photo `name` as (H, W, 3) uint8 RGB.

    Raises:
        CameraError: an unknown name, or scikit-image missing (the ``camera`` extra).
    """
    try:
        from skimage import data
    except ImportError:
        raise CameraError("the sample photos need scikit-image: pip install -c requirements.lock -e '.[camera]'") \
            from None
    if name == "astronaut":
        return np.ascontiguousarray(data.astronaut())
    if name == "cameraman":
        return np.ascontiguousarray(np.dstack([data.camera()] * 3))
    if name == "cat":
        return np.ascontiguousarray(data.chelsea())
    if name == "coffee":
        return np.ascontiguousarray(data.coffee())
    if name == "hopper":
        import matplotlib.cbook

        path = matplotlib.cbook.get_sample_data("grace_hopper.jpg", asfileobj=False)
        bgr = cv2.imread(str(path))
        if bgr is None:
            raise CameraError(f"matplotlib's sample photo {path} cannot be read")
        return np.ascontiguousarray(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
    raise CameraError(f"unknown sample photo {name!r} (one of {', '.join(PEOPLE)})")


#: The sample camera's frame (width, height), px: two 512-px slots side by side.
CANVAS = (1024, 512)
SLOTS = ("left", "right", "centre")


@dataclass(frozen=True)
class Placed:
    """A photo placed on the canvas: its name, scale and top-left corner, px."""

    name: str
    scale: float
    x0: int
    y0: int

    def label_px(self, joint: str) -> np.ndarray:
        """A labelled joint's (2,) pixel on the canvas."""
        x, y = LABELS[self.name][joint]
        return np.array([self.x0 + x * self.scale, self.y0 + y * self.scale])


def compose(names: list[tuple[str, str]]) -> tuple[np.ndarray, list[Placed]]:
    """A canvas frame with photos (name, slot) scaled to 512 px high, each in its slot
    (``left``, ``right`` or ``centre``), on grey. Returns the frame (H, W, 3) and the placements."""
    w, h = CANVAS
    canvas = np.full((h, w, 3), 128, np.uint8)
    placed = []
    for name, slot in names:
        img = photo(name)
        scale = min(h / img.shape[0], 512 / img.shape[1])
        img = cv2.resize(img, (round(img.shape[1] * scale), round(img.shape[0] * scale)), interpolation=cv2.INTER_AREA)
        centre = {"left": 256, "right": 768, "centre": 512}[slot]
        x0, y0 = centre - img.shape[1] // 2, (h - img.shape[0]) // 2
        canvas[y0:y0 + img.shape[0], x0:x0 + img.shape[1]] = img
        placed.append(Placed(name, scale, x0, y0))
    return canvas, placed


def flat_depth(distances_m: dict[str, float]) -> np.ndarray:
    """A depth image (H, W) uint16 mm of the canvas: each slot's photo is a flat print held
    at its distance (``left``/``right``/``centre`` → m); elsewhere no reading (0)."""
    w, h = CANVAS
    depth = np.zeros((h, w), np.uint16)
    for slot, d in distances_m.items():
        x0 = {"left": 0, "right": 512, "centre": 256}[slot]
        depth[:, x0:x0 + 512] = int(round(d * 1000.0))
    return depth


def write_frames(folder: Path, frames: list[tuple[np.ndarray, np.ndarray]], video: bool = False) -> None:
    """Write (rgb, depth_mm) frames as ``rgb/NNNN.png`` (or ``rgb.avi``, lossless PNG codec)
    and ``depth/NNNN.png`` (16-bit, mm) under `folder`."""
    (folder / "depth").mkdir(parents=True, exist_ok=True)
    writer = None
    if video:
        w, h = CANVAS
        writer = cv2.VideoWriter(str(folder / "rgb.avi"), cv2.VideoWriter.fourcc(*"png "), 15.0, (w, h))
        if not writer.isOpened():
            raise CameraError(f"OpenCV cannot write {folder / 'rgb.avi'}")
    else:
        (folder / "rgb").mkdir(parents=True, exist_ok=True)
    for i, (rgb, depth) in enumerate(frames):
        bgr = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
        if writer is not None:
            writer.write(bgr)
        else:
            cv2.imwrite(str(folder / "rgb" / f"{i:04d}.png"), bgr)
        cv2.imwrite(str(folder / "depth" / f"{i:04d}.png"), depth)
    if writer is not None:
        writer.release()


#: The sample camera (deploy/camera.toml): a wide-angle camera on a stand 0.44 m behind
#: the scene's base origin, level, looking along base x; the photo is a print 1.5 m in front of it,
#: where the simulated receiver stands.
SAMPLE_INTRINSICS_PX = {"fx_px": 400.0, "fy_px": 400.0, "cx_px": 512.0, "cy_px": 256.0}
SAMPLE_CAMERA_POSITION_M = (-0.44, -0.02, 0.29)
SAMPLE_DISTANCE_M = 1.5
SAMPLE_SCENE = [("cameraman", "right")]


def sample_calibration_text() -> str:
    """The sample camera's calibration file (the ROS 1 path's format)."""
    x, y, z = SAMPLE_CAMERA_POSITION_M
    return ("# The sample camera's pose in the scene's base frame (camera_link: x forward, y left, z up),\n"
            "# written by `handover-tracker camera-sample` (services/tracker/camera/photos.py).\n"
            f'frame = "camera_link"\nposition_m = [{x}, {y}, {z}]\nrpy_deg = [0.0, 0.0, 0.0]\n'
            'measured = "exact: the sample camera of services/tracker/camera/photos.py"\n')


def write_sample(folder: Path) -> int:
    """Write the sample camera input under `folder`: ``rgb/0000.png``, ``depth/0000.png``
    (the print 1.5 m away) and ``calibration.toml``. Returns the number of frames."""
    rgb, _ = compose(SAMPLE_SCENE)
    depth = flat_depth({slot: SAMPLE_DISTANCE_M for _, slot in SAMPLE_SCENE})
    write_frames(folder, [(rgb, depth)])
    (folder / "calibration.toml").write_text(sample_calibration_text())
    return 1
