"""The camera path end to end, real processes on a loopback bus:

- a video built from real photographs (a cat, the cameraman, the astronaut beside the
  cameraman) replayed through the tracker service: nobody → not tracked; the cameraman → his
  shoulder where the labelled pixel and the print's depth put it in `base`; two people → the
  one nearer the transfer centre is the receiver; the video's end stops the tracker cleanly;
- `deploy/camera.toml`: the whole handover job with the sim robot driven by camera perception;
- the same with nobody in view: the supervisor never starts the pick.
"""

from __future__ import annotations

import queue
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mediapipe", reason="the camera extra is not installed: pip install -e '.[camera]' && "
                                        "pip install --no-deps mediapipe==0.10.14 (docs/camera.md#install)")
pytest.importorskip("skimage", reason="the camera extra (scikit-image's photos) is not installed")

from bus_schema import topics as T  # noqa: E402
from bus_schema.codec import decode  # noqa: E402
from services.runtime.profile import free_tcp_port  # noqa: E402
from services.runtime.testing import (BusRouter, ServiceProcess, client_session, run_launcher,
                                      loopback_profile, wait_alive)
from services.tracker.camera import photos  # noqa: E402

pytestmark = pytest.mark.integration
REPO = Path(__file__).resolve().parents[2]
N = 8  # frames per scene (10 Hz)


def expected_base_m(pixel: np.ndarray, depth_m: float) -> np.ndarray:
    """The sample camera's back-projection (level, looking along base x) of a pixel at a depth."""
    k = photos.SAMPLE_INTRINSICS_PX
    x, y, z = photos.SAMPLE_CAMERA_POSITION_M
    return np.array([x + depth_m, y - (pixel[0] - k["cx_px"]) / k["fx_px"] * depth_m,
                     z - (pixel[1] - k["cy_px"]) / k["fy_px"] * depth_m])


def camera_profile(tmp: Path, extra: str = "") -> Path:
    text = (REPO / "deploy" / "camera.toml").read_text()
    (tmp / "camera_sample").mkdir(exist_ok=True)
    (tmp / "camera_sample" / "calibration.toml").write_text(photos.sample_calibration_text())
    path = tmp / "camera.toml"
    path.write_text(text + extra)
    return path


def test_a_video_of_photographs_through_the_tracker_service(tmp_path):
    cat, _ = photos.compose([("cat", "centre")])
    man, placed = photos.compose([("cameraman", "right")])
    two, _ = photos.compose([("astronaut", "left"), ("cameraman", "right")])
    frames = ([(cat, photos.flat_depth({"centre": 1.5}))] * N + [(man, photos.flat_depth({"right": 1.5}))] * N
              + [(two, photos.flat_depth({"left": 1.5, "right": 1.5}))] * N)
    photos.write_frames(tmp_path / "camera_sample", frames, video=True)
    profile_path = camera_profile(tmp_path, "")
    text = profile_path.read_text().replace('input = "camera_sample/rgb"', 'input = "camera_sample/rgb.avi"')
    profile_path.write_text(text.replace("loop = true", "loop = false"))
    profile = loopback_profile(profile=str(profile_path))
    skeletons: queue.Queue = queue.Queue()
    with BusRouter(profile):
        session = client_session(profile)
        sub = session.declare_subscriber(T.SKELETON.key(profile.prefix),
                                         lambda s: skeletons.put((time.monotonic(), decode(T.SKELETON,
                                                                                           s.payload.to_bytes()))))
        try:
            with ServiceProcess("services.tracker", profile, name="tracker") as proc:
                wait_alive(session, profile, {"tracker"}, timeout_s=60.0)
                assert proc.proc.wait(60.0) == 0, proc.log_text()  # the video's end stops it
                log = proc.log_text()
        finally:
            sub.undeclare()
    got = []
    while not skeletons.empty():
        got.append(skeletons.get()[1])
    tracked = [s for s in got if s.tracked]
    untracked_first = next(i for i, s in enumerate(got) if not s.tracked)
    assert untracked_first < next(i for i, s in enumerate(got) if s.tracked), log  # the cat came first
    assert len(tracked) >= N, log  # the cameraman, then the cameraman again beside the astronaut
    shoulder = expected_base_m(placed[0].label_px("right_shoulder"), 1.5)
    tol_m = photos.HALF_BOX_PX / photos.SAMPLE_INTRINSICS_PX["fx_px"] * 1.5  # the pixel box at 1.5 m
    for s in tracked:
        joints = {j.name: np.array(j.position_m) for j in s.joints}
        assert np.all(np.abs(joints["right_shoulder"] - shoulder) <= tol_m + 1e-6), (joints["right_shoulder"], shoulder)
    assert "2 person(s) in view" in log, log  # both seen; the cameraman (nearer the transfer centre) stays
    assert "camera stopped" in log and "out_of_order=0" in log, log


def run_camera_profile(profile_path: Path, tmp: Path, timeout_s: float = 150.0) -> tuple[int, str]:
    return run_launcher(["--profile", str(profile_path), "--port", str(free_tcp_port()), "--recording-dir",
                         str(tmp / "rec"), "--episodes", "1", "--verbose"], timeout_s)


def test_the_camera_profile_runs_the_whole_handover(tmp_path):
    profile = camera_profile(tmp_path)
    shutil.copytree(REPO / "deploy" / "camera_sample" / "rgb", tmp_path / "camera_sample" / "rgb")
    shutil.copytree(REPO / "deploy" / "camera_sample" / "depth", tmp_path / "camera_sample" / "depth")
    code, out = run_camera_profile(profile, tmp_path)
    tail = out[-6000:]
    assert code == 0, tail
    assert "RELEASED: released to the receiver" in out, tail
    assert "never dropped" in out, tail
    assert "camera: 1 person(s) in view" in out, tail


def test_nobody_in_view_means_no_pick(tmp_path):
    profile = camera_profile(tmp_path, "")
    profile.write_text(profile.read_text().replace("transfer_timeout_s = 6.0", "transfer_timeout_s = 6.0\n"
                                                   "locate_timeout_s = 6.0"))
    cat, _ = photos.compose([("cat", "centre")])
    photos.write_frames(tmp_path / "camera_sample", [(cat, photos.flat_depth({"centre": 1.5}))])
    code, out = run_camera_profile(profile, tmp_path)
    assert "locate: the tracker did not find the receiver" in out, out[-6000:]
    assert "pick (approach)" not in out, out[-6000:]
    assert "camera: nobody in view" in out, out[-6000:]
    assert code != 0 or "FAILED" in out.upper(), out[-6000:]
