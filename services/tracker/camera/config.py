"""Typed settings of the camera input (``[services.tracker.config.camera]``, docs/camera.md)."""

from __future__ import annotations

from typing import Annotated

import msgspec
from msgspec import Meta

from handover_model import scene

Metres = Annotated[float, Meta(ge=-10.0, le=10.0)]


def _transfer_centre() -> list[float]:
    return [float(v) for v in scene.TABLE_TOP_CENTRE_BASE_M]


class CameraConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """An ordinary camera (webcam, RealSense, a video file, an image folder) and a 2-D body-pose
    model (MediaPipe Pose, CPU, weights inside the ``mediapipe`` wheel).

    Attributes:
        input: where colour frames come from: a device index (``"0"``), a video file, a folder
            of images (sorted by name), or ``"realsense"`` (colour and aligned depth from
            ``pyrealsense2``). Paths are relative to the profile's folder.
        depth: aligned depth: ``"none"`` (distance from the apparent shoulder width, a webcam),
            a folder of 16-bit PNG images in millimetres, one per colour frame in name order,
            or ``"realsense"`` (with ``input = "realsense"``).
        calibration_file: the camera frame's pose in `base` (the ROS 1 path's TOML format,
            `services.tracker.ros1.calibration`; camera frame x forward, y left, z up, as a
            RealSense's ``camera_link``). Required.
        camera_frame: the frame name the calibration file must carry (if it names one).
        fx_px, fy_px, cx_px, cy_px: pinhole intrinsics of the colour image, px (0: from the
            RealSense; for other inputs required).
        rate_hz: frames processed per second at most (others are skipped and counted); a
            file or a folder is read at this rate, a live camera delivers its own.
        loop: start a video file or image folder over when it ends (else the source ends).
        stall_s: a camera that delivers no frame for this long is reported lost, s.
        max_people: people looked for in each frame (1: the first found is taken, no check
            for a second).
        min_visibility: a landmark less visible than this (MediaPipe's 0..1) is left out of
            the skeleton.
        shoulder_width_m: the receiver's shoulder-joint distance, m, for ``depth = "none"``.
        transfer_centre_m, max_receiver_distance_m, switch_margin_m: the receiver rule
            (`services.tracker.camera.people.choose_receiver`).
        object_position_m: the object's place on the table from the task description, m,
            `base` (x, y, z), published as the object estimate: the camera path does not look
            for the object. Required.
    """

    input: Annotated[str, Meta(min_length=1, max_length=4096)] = "0"
    depth: Annotated[str, Meta(min_length=1, max_length=4096)] = "none"
    calibration_file: Annotated[str, Meta(max_length=4096)] = ""
    camera_frame: Annotated[str, Meta(min_length=1, max_length=200)] = "camera_link"
    fx_px: Annotated[float, Meta(ge=0.0, le=1e5)] = 0.0
    fy_px: Annotated[float, Meta(ge=0.0, le=1e5)] = 0.0
    cx_px: Annotated[float, Meta(ge=0.0, le=1e5)] = 0.0
    cy_px: Annotated[float, Meta(ge=0.0, le=1e5)] = 0.0
    rate_hz: Annotated[float, Meta(gt=0.0, le=120.0)] = 15.0
    loop: bool = False
    stall_s: Annotated[float, Meta(gt=0.0, le=60.0)] = 1.0
    max_people: Annotated[int, Meta(ge=1, le=6)] = 2
    min_visibility: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.5
    shoulder_width_m: Annotated[float, Meta(ge=0.2, le=0.6)] = 0.36
    transfer_centre_m: Annotated[list[Metres], Meta(min_length=3, max_length=3)] = msgspec.field(
        default_factory=_transfer_centre)
    max_receiver_distance_m: Annotated[float, Meta(gt=0.0, le=10.0)] = 1.5
    switch_margin_m: Annotated[float, Meta(ge=0.0, le=5.0)] = 0.3
    object_position_m: Annotated[list[Metres], Meta(max_length=3)] = msgspec.field(default_factory=list)

    def problems(self) -> list[str]:
        """What is wrong with this camera set-up (empty when it can run)."""
        out = []
        if not self.calibration_file:
            out.append("camera.calibration_file is required: the camera's pose in base (docs/camera.md#calibration)")
        if self.input != "realsense" and min(self.fx_px, self.fy_px, self.cx_px, self.cy_px) <= 0.0:
            out.append("camera.fx_px, fy_px, cx_px, cy_px are required for a camera other than a RealSense "
                       "(docs/camera.md#intrinsics)")
        if self.depth == "realsense" and self.input != "realsense":
            out.append('camera.depth = "realsense" needs camera.input = "realsense"')
        if len(self.object_position_m) != 3:
            out.append("camera.object_position_m needs 3 values (x, y, z): the object's place on the table "
                       "in base, m (the camera path does not look for the object)")
        return out
