"""The ROS 1 Kinect path's messages: MD5 sums against the published values, bytes written by
hand from the wire-format rules, round trips, and decoders fed random and cut bytes."""

from __future__ import annotations

import random
import struct

import pytest

from services.bridge.baxter.messages import Header, Vector3
from services.bridge.baxter.ros1 import Ros1DecodeError, Time
from services.tracker.ros1.messages import CameraInfo, Image, Quaternion, TFMessage, Transform, TransformStamped


def u32(v: int) -> bytes:
    return struct.pack("<I", v)


def string(s: str) -> bytes:
    return u32(len(s)) + s.encode()


def f64(*values: float) -> bytes:
    return struct.pack(f"<{len(values)}d", *values)


@pytest.mark.parametrize(("cls", "md5"), [
    (TFMessage, "94810edda583a504dfda3829e70d7eec"),
    (TransformStamped, "b5764a33bfeb3588febc2682852579b0"),
    (Transform, "ac9eff44abf714214112b05d54a3cf9b"),
    (Quaternion, "a779879fadf0160734f906b8c19c7004"),
    (Image, "060021388200f6f0f447d0fcd9c64743"),
    (CameraInfo, "c9a58c1b0b154e0e6da7578cb991d214"),
])
def test_md5_sums_are_the_published_ones(cls, md5):
    assert cls.md5sum() == md5


def test_a_tf_message_is_the_hand_written_bytes():
    msg = TFMessage((TransformStamped(Header(seq=3, stamp=Time(10, 20), frame_id="openni_depth_frame"),
                                      "right_hand_1", Transform(Vector3(1.5, -0.25, 0.5), Quaternion(0, 0, 0, 1))),))
    wire = (u32(1) + u32(3) + u32(10) + u32(20) + string("openni_depth_frame") + string("right_hand_1")
            + f64(1.5, -0.25, 0.5) + f64(0.0, 0.0, 0.0, 1.0))
    assert msg.to_bytes() == wire
    assert TFMessage.from_bytes(wire) == msg


def test_a_depth_image_is_the_hand_written_bytes_and_its_data_stays_bytes():
    data = bytes(range(8))  # 2 x 2 pixels, 16UC1
    msg = Image(Header(seq=1, stamp=Time(2, 3), frame_id="d"), 2, 2, "16UC1", 0, 4, data)
    wire = u32(1) + u32(2) + u32(3) + string("d") + u32(2) + u32(2) + string("16UC1") + b"\x00" + u32(4) + u32(8) + data
    assert msg.to_bytes() == wire
    decoded = Image.from_bytes(wire)
    assert decoded == msg and isinstance(decoded.data, bytes)


def test_camera_info_round_trips_with_its_intrinsics():
    k = (285.5, 0.0, 159.5, 0.0, 285.5, 119.5, 0.0, 0.0, 1.0)
    msg = CameraInfo(Header(frame_id="camera_depth_optical_frame"), 240, 320, "plumb_bob", (0.0,) * 5, k)
    data = msg.to_bytes()
    # The 9 K values follow the header, sizes, model and the 5 D values (fixed-size K: no length).
    offset = 4 + 8 + 4 + len("camera_depth_optical_frame") + 8 + 4 + len("plumb_bob") + 4 + 5 * 8
    assert struct.unpack_from("<9d", data, offset) == k
    assert CameraInfo.from_bytes(data) == msg


@pytest.mark.parametrize("cls", [TFMessage, Image, CameraInfo])
def test_cut_random_and_mutated_bytes_raise_only_the_decode_error(cls):
    rng = random.Random(7)
    valid = {TFMessage: TFMessage((TransformStamped(child_frame_id="head_1"),)),
             Image: Image(height=1, width=2, encoding="16UC1", step=4, data=b"\x01\x02\x03\x04"),
             CameraInfo: CameraInfo()}[cls].to_bytes()
    for cut in range(len(valid)):
        with pytest.raises(Ros1DecodeError):
            cls.from_bytes(valid[:cut])
    with pytest.raises(Ros1DecodeError):
        cls.from_bytes(valid + b"\x00")
    for _ in range(2000):
        data = bytearray(valid)
        for _ in range(rng.randrange(1, 4)):
            data[rng.randrange(len(data))] = rng.randrange(256)
        try:
            cls.from_bytes(bytes(data))
        except Ros1DecodeError:
            pass
        random_bytes = bytes(rng.getrandbits(8) for _ in range(rng.randrange(0, 120)))
        try:
            cls.from_bytes(random_bytes)
        except Ros1DecodeError:
            pass


def test_a_huge_declared_length_is_refused_without_allocating_it():
    with pytest.raises(Ros1DecodeError):
        TFMessage.from_bytes(b"\xff\xff\xff\x7f")
    with pytest.raises(Ros1DecodeError):
        Image.from_bytes(u32(0) * 3 + u32(0) + u32(1) + u32(1) + string("16UC1") + b"\x00" + u32(2)
                         + b"\xff\xff\xff\x7f")
