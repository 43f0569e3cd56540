"""`handover-recorder screenshot` on a real recording of a handover, with the real viewer
headless (skipped, saying why, without Xvfb and Mesa's software Vulkan: not on the CI machine)."""

from __future__ import annotations

import hashlib
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from tests.integration.headless_viewer import handover_recording

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    return handover_recording(tmp_path_factory.mktemp("shot"), "shot")


@pytest.mark.timeout(400)
def test_a_screenshot_of_a_handover_shows_the_scene_and_leaves_the_recording_as_it_was(recording, tmp_path):
    before = hashlib.sha256(recording.read_bytes()).hexdigest()
    output = tmp_path / "pictures" / "run.png"
    done = subprocess.run([sys.executable, "-m", "services.recorder", "screenshot", str(recording),
                           "--output", str(output), "--size", "800x500"],
                          stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=380)
    assert done.returncode == 0, done.stdout + done.stderr
    assert hashlib.sha256(recording.read_bytes()).hexdigest() == before
    with Image.open(output) as picture:
        assert picture.size[0] >= 800 and picture.size[1] >= 500  # the window, at the display's scale
        assert done.stdout.strip() == f"screenshot: {output} ({picture.size[0]}x{picture.size[1]} px) of {recording}"
        pixels = np.asarray(picture.convert("RGB"), dtype=float)
    # A drawn viewer, not a blank window: many colours, and the 3-D view (left) differs from the
    # signal panels (right).
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 200
    width = pixels.shape[1]
    assert np.abs(pixels[:, : width // 2].mean(axis=(0, 1)) - pixels[:, width // 2:].mean(axis=(0, 1))).max() > 1.0
    # No viewer left behind (its command line names the command's temporary folder).
    left = subprocess.run(["pgrep", "-f", "handover-screenshot-"], capture_output=True, text=True)
    assert left.stdout.strip() == "", left.stdout
