"""2-D body pose of every person in a colour image: MediaPipe Pose (BlazePose GHUM, "full").

The model's weights (``pose_detection.tflite``, ``pose_landmark_full.tflite``) ship inside the
``mediapipe==0.10.14`` wheel; ``model_complexity=1`` is the one variant that is not downloaded at
run time (0 and 2 are), so it is the only one used here. The package is optional
(``pip install -e '.[camera]'`` then ``pip install --no-deps mediapipe==0.10.14``:
docs/camera.md#install says why).

MediaPipe's legacy Pose solution finds one person per image. `PoseEstimator.people` finds up
to ``max_people``: it runs the model, blanks the person found (the box of their head and
torso landmarks, widened) and runs it again, until nobody more is found. Each person comes
back with all 33 landmarks in pixels and their visibility (0..1).
"""

from __future__ import annotations

import contextlib
import os
import warnings
from dataclasses import dataclass

import numpy as np

from services.tracker.errors import CameraError

#: MediaPipe Pose landmark indices used here (BlazePose's 33-point topology).
LM = {"nose": 0, "left_ear": 7, "right_ear": 8, "left_shoulder": 11, "right_shoulder": 12,
      "left_elbow": 13, "right_elbow": 14, "left_wrist": 15, "right_wrist": 16, "left_pinky": 17,
      "right_pinky": 18, "left_index": 19, "right_index": 20, "left_hip": 23, "right_hip": 24,
      "left_knee": 25, "right_knee": 26, "left_ankle": 27, "right_ankle": 28}
#: Landmarks whose box is blanked to look for the next person (head and trunk: arms may cross).
CORE = (0, 7, 8, 11, 12, 23, 24)
#: The blanked box is widened by this fraction of its width on each side.
BLANK_MARGIN = 0.15


@dataclass(frozen=True)
class Person2D:
    """One person's landmarks in an image.

    Attributes:
        xy_px: (33, 2) landmark pixel coordinates (x right, y down; may lie outside the image).
        visibility: (33,) MediaPipe's visibility, 0..1.
    """

    xy_px: np.ndarray
    visibility: np.ndarray

    def point(self, name: str) -> tuple[np.ndarray, float]:
        """A landmark's (2,) pixel position and visibility."""
        i = LM[name]
        return self.xy_px[i], float(self.visibility[i])

    def core_box(self, min_visibility: float) -> tuple[float, float, float, float] | None:
        """(x0, y0, x1, y1) px around the visible head and trunk landmarks, or None."""
        idx = [i for i in CORE if self.visibility[i] >= min_visibility]
        if len(idx) < 2:
            return None
        xy = self.xy_px[idx]
        x0, y0 = xy.min(axis=0)
        x1, y1 = xy.max(axis=0)
        return float(x0), float(y0), float(x1), float(y1)

    def upright(self, min_visibility: float) -> bool:
        """Visible hips below the shoulders, the nose no lower than half a shoulder width below
        them (image y grows downward; a person bending over a camera still counts)."""
        y = self.xy_px[:, 1]
        shoulders_y = 0.5 * (y[LM["left_shoulder"]] + y[LM["right_shoulder"]])
        hips = [LM["left_hip"], LM["right_hip"]]
        hips_ok = all(y[i] > shoulders_y for i in hips if self.visibility[i] >= min_visibility)
        return bool(y[LM["nose"]] < shoulders_y + 0.5 * self.shoulder_width_px and hips_ok)

    @property
    def shoulder_width_px(self) -> float:
        return float(np.linalg.norm(self.xy_px[LM["left_shoulder"]] - self.xy_px[LM["right_shoulder"]]))


def _import_mediapipe():
    os.environ.setdefault("GLOG_minloglevel", "2")  # MediaPipe's C++ log: errors only
    os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "2")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # protobuf's deprecation notes
            from mediapipe.python.solutions import pose as mp_pose  # type: ignore[import-untyped]
    except ImportError as exc:
        raise CameraError(f"the camera path needs MediaPipe ({exc}): pip install -c requirements.lock -e "
                          "'.[camera]' && pip install --no-deps mediapipe==0.10.14 (docs/camera.md#install)") from None
    return mp_pose


class PoseEstimator:
    """MediaPipe Pose on the CPU, several people per image (see the module docstring).

    Args:
        max_people: look for at most this many people per image.
        min_visibility: landmarks below it do not count for a person's box.
        min_detection_confidence: MediaPipe's person-detector threshold.

    Raises:
        CameraError: MediaPipe is not installed.
    """

    def __init__(self, max_people: int = 2, min_visibility: float = 0.5,
                 min_detection_confidence: float = 0.5) -> None:
        mp_pose = _import_mediapipe()
        self.max_people, self.min_visibility = max_people, min_visibility
        with _native_stderr_quiet():  # TFLite's start-up notes (XNNPACK, feedback manager) on fd 2
            # static_image_mode: the person detector runs on every image (several people, no
            # tracking across frames that blanking would confuse); complexity 1 = the shipped model.
            self._pose = mp_pose.Pose(static_image_mode=True, model_complexity=1, enable_segmentation=False,
                                      min_detection_confidence=min_detection_confidence)
            self._pose.process(np.full((64, 64, 3), 128, np.uint8))  # warm-up: the graph starts here
        self.inferences = 0

    def people(self, rgb: np.ndarray) -> list[Person2D]:
        """The people in `rgb` ((H, W, 3) uint8, RGB), in the order found (MediaPipe's most
        confident first). A "person" not upright (`Person2D.upright`) is what the model
        makes of an empty or blanked region: it ends the search and is not returned."""
        if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
            raise ValueError(f"expected an (H, W, 3) uint8 RGB image, got {rgb.shape} {rgb.dtype}")
        h, w = rgb.shape[:2]
        work = np.ascontiguousarray(rgb)
        found: list[Person2D] = []
        while len(found) < self.max_people:
            with warnings.catch_warnings():  # protobuf's deprecation note, on every image otherwise
                warnings.filterwarnings("ignore", message=r"SymbolDatabase\.GetPrototype")
                result = self._pose.process(work)
            self.inferences += 1
            if result.pose_landmarks is None:
                break
            lms = result.pose_landmarks.landmark
            person = Person2D(np.array([(lm.x * w, lm.y * h) for lm in lms]),
                              np.array([lm.visibility for lm in lms]))
            if not person.upright(self.min_visibility):
                break
            found.append(person)
            box = person.core_box(self.min_visibility)
            if box is None or len(found) == self.max_people:
                break
            work = _blank(work.copy() if len(found) == 1 else work, box)
        return found

    def close(self) -> None:
        self._pose.close()


@contextlib.contextmanager
def _native_stderr_quiet():
    """Send file descriptor 2 to a temporary file while MediaPipe's C++ starts (only this thread
    runs then: the tracker opens the camera before it joins the bus); what it said is logged at
    debug level."""
    import logging
    import sys
    import tempfile

    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            said = sink.read().decode(errors="replace").strip()
            if said:
                logging.getLogger("tracker").debug("MediaPipe start-up: %s", said.replace("\n", " | "))


def _blank(image: np.ndarray, box: tuple[float, float, float, float]) -> np.ndarray:
    """`image` with the widened `box` (x0, y0, x1, y1, px) filled grey, full height below the
    top of the head (a person's body continues downward)."""
    h, w = image.shape[:2]
    x0, y0, x1, _ = box
    margin = BLANK_MARGIN * max(x1 - x0, 1.0)
    top = max(0, int(y0 - 2.0 * margin))
    image[top:, max(0, int(x0 - margin)):min(w, int(np.ceil(x1 + margin)))] = 128
    return image
