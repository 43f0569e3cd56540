"""The depth camera's ``sensor_msgs/Image`` + ``CameraInfo`` → `perception/depth` fields.

Why a depth image and not ``sensor_msgs/PointCloud2``: the tracker's input is a depth image
with its intrinsics (`bus_schema.messages.DepthImage`), which is what openni_launch publishes
natively (``/camera/depth/image_raw``, ``16UC1`` mm, with ``camera_info``). A 320x240 image is
150 kB; the same scene as an XYZ cloud is 1.2 MB (16 bytes a point), over the bus's 1 MiB
message cap, and a 640x480 cloud is 4.9 MB; the cloud would also be converted back into an
image for the tracker's window search. Accepted encodings: ``16UC1`` / ``mono16`` (mm) and
``32FC1`` (m, NaN for no reading), either byte order.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bus_schema.types import MAX_PAYLOAD_BYTES
from services.tracker.ros1.calibration import CameraPose
from services.tracker.ros1.messages import CameraInfo, Image

#: The largest image side `DepthImage` takes, px.
MAX_SIDE_PX = 1024


class DepthConversionError(ValueError):
    """An image that cannot be a depth frame (one line: what is wrong)."""


def _depth_mm(image: Image) -> np.ndarray:
    """(H, W) uint16 mm, little-endian, from the image's data."""
    h, w = image.height, image.width
    dtype: np.dtype
    if image.encoding in ("16UC1", "mono16"):
        size, dtype = 2, np.dtype(">u2" if image.is_bigendian else "<u2")
    elif image.encoding == "32FC1":
        size, dtype = 4, np.dtype(">f4" if image.is_bigendian else "<f4")
    else:
        raise DepthConversionError(f"depth encoding {image.encoding!r} is not 16UC1, mono16 or 32FC1")
    if image.step < w * size or len(image.data) != image.step * h:
        raise DepthConversionError(f"depth image {w}x{h} {image.encoding}: step {image.step} and "
                                   f"{len(image.data)} data bytes do not match")
    rows = np.frombuffer(image.data, np.uint8).reshape(h, image.step)[:, : w * size]
    values = np.ascontiguousarray(rows).view(dtype).reshape(h, w)
    if size == 2:
        return values.astype("<u2", copy=False)
    with np.errstate(invalid="ignore"):
        mm = np.where(np.isfinite(values) & (values > 0), np.rint(values * 1000.0), 0.0)
    return np.clip(mm, 0, 65535).astype("<u2")


def depth_fields(image: Image, info: CameraInfo, pose: CameraPose) -> dict[str, Any]:
    """`bus_schema.messages.DepthImage` fields (no header) of a depth image.

    The intrinsics come from ``info.K``; the camera pose in `base` is the calibration's
    optical frame (`CameraPose.optical_rotation`).

    Raises:
        DepthConversionError: wrong encoding, sizes that disagree with the data or with the
            camera info, an image too large for the bus, intrinsics that are not positive.
    """
    h, w = image.height, image.width
    if not (1 <= w <= MAX_SIDE_PX and 1 <= h <= MAX_SIDE_PX) or 2 * w * h > MAX_PAYLOAD_BYTES - 4096:
        raise DepthConversionError(f"depth image {w}x{h} is empty or too large (at most {MAX_SIDE_PX} px a side)")
    if (info.width, info.height) != (w, h):
        raise DepthConversionError(f"camera_info is for {info.width}x{info.height}, the image is {w}x{h}: "
                                   "are both topics of the same camera and mode?")
    k = np.asarray(info.K, float)
    if k.shape != (9,) or not np.all(np.isfinite(k)) or not (0 < k[0] <= 1e5 and 0 < k[4] <= 1e5) \
            or not (abs(k[2]) <= 1e5 and abs(k[5]) <= 1e5):
        raise DepthConversionError(f"camera_info K {tuple(info.K)} has no positive focal lengths")
    mm = _depth_mm(image)
    return {"width": w, "height": h, "depth_mm": mm.tobytes(), "fx": float(k[0]), "fy": float(k[4]),
            "cx": float(k[2]), "cy": float(k[5]), "camera_position_m": tuple(float(v) for v in pose.position_m),
            "camera_orientation_xyzw": pose.optical_orientation_xyzw()}
