"""A picture of a handover recording in the real Rerun viewer, on a machine without a display.

``handover-recorder screenshot RUN.rrd [--output PNG] [--size WxH]`` runs the viewer of the
project's venv headless (`services.recorder.headless`: a private Xvfb display, Mesa's software
Vulkan, loopback only, analytics off in private folders) on the recorder's blueprint with the
time cursor at the end of the run, and uses the viewer's own ``--screenshot-to``.

The viewer takes its picture after a few frames, not when it has read the whole file: the
recorder's file (thousands of small chunks) is first compacted with ``rerun rrd optimize`` into
a temporary copy (a few hundred chunks), which the viewer reads in time; otherwise entities
whose chunks were not read yet (the skeleton, the hands) are missing. The recording itself is
not touched. The arm drawn is the one the recording holds (the built-in arm whose URDF the
recorder logged), with what the viewer cannot draw of it hidden as the recorder's own layout
hides it. Takes about 6 s for a default run on two cores (software rendering; longer runs,
longer).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from typing import Any

from services.recorder.errors import RecorderError
from services.recorder.headless import (
    HeadlessViewerError,
    die_with_parent,
    headless_display,
    missing,
    on_display,
    one_line,
    private_env,
    viewer_binary,
)
from services.runtime.paths import unwritable_dir

#: How long the viewer may take to read the file and draw, s.
VIEWER_TIMEOUT_S = 300.0
#: How long `rerun rrd optimize` may take to compact the recording, s.
OPTIMIZE_TIMEOUT_S = 300.0
_SIZE = re.compile(r"^(\d{2,5})x(\d{2,5})$")
_GEOMETRY = ("visual_geometries", "collision_geometries")


def parse_size(size: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` in pixels, each 16–16384.

    Raises:
        RecorderError: anything else.
    """
    match = _SIZE.match(size)
    width, height = (int(match.group(1)), int(match.group(2))) if match else (0, 0)
    if not (16 <= width <= 16384 and 16 <= height <= 16384):
        raise RecorderError(f"--size {size!r} must look like 1600x1000 (16–16384 pixels each way)")
    return width, height


def recorded_robot(entities: list[str]) -> str | None:
    """The arm a recording draws: the root of its URDF's geometry entities
    (``/<robot>/visual_geometries/…``), or None when it holds no arm model."""
    for entity in entities:
        parts = entity.strip("/").split("/")
        if len(parts) > 2 and parts[1] in _GEOMETRY:
            return parts[0]
    return None


def recorded_arm(robot_name: str | None) -> Any:
    """The built-in arm (`handover_model.robots.RobotDescription`) whose placed URDF is named
    `robot_name` (the root of a recording's arm entities), or None."""
    from handover_model import robots

    for desc in robots.BUILTIN.values():
        robots.urdf_path(desc)  # resolves the package's meshes for the placed file
        if ET.parse(robots.placed_urdf_file(desc)).getroot().get("name") == robot_name:
            return desc
    return None


def check_paths(recording: Path, output: Path) -> None:
    """Refuse, before any work, a missing recording or an output that is not a writable .png
    (its folder is made if missing).

    Raises:
        RecorderError: what to check, in one line.
    """
    if not recording.is_file():
        raise RecorderError(f"recording {recording} does not exist")
    if output.suffix != ".png":
        raise RecorderError(f"--output {output} must end in .png")
    if output.is_dir():
        raise RecorderError(f"--output {output} is a folder; name a .png file")
    why = unwritable_dir(output.parent)
    if why is not None:
        raise RecorderError(f"--output {output}: cannot write into {output.parent} ({why})")


def _run(command: list[str], what: str, timeout_s: float, env: dict[str, str] | None = None,
         preexec_fn: Callable[[], None] | None = die_with_parent) -> None:
    """Run a helper program (it dies with this process); its output's end in the error."""
    try:
        done = subprocess.run(command, stdin=subprocess.DEVNULL, capture_output=True, text=True,
                              timeout=timeout_s, env=env, preexec_fn=preexec_fn)
    except subprocess.TimeoutExpired:
        raise HeadlessViewerError(f"{what} did not finish in {timeout_s:.0f} s") from None
    if done.returncode != 0:
        raise HeadlessViewerError(f"{what} failed (exit {done.returncode}): {one_line(done.stderr or done.stdout)}")


def _layout(recording: Path, path: Path) -> None:
    """The recorder's blueprint for `recording`'s arm, following the newest data, saved to `path`."""
    from handover_model import robots
    from services.recorder.blueprint import blueprint
    from services.recorder.readback import entity_row_counts

    robot = recorded_robot(list(entity_row_counts(recording)))
    arm = recorded_arm(robot)
    if arm is not None:
        robots.use(arm)  # the blueprint hides what the viewer cannot draw of the active arm
    blueprint(robot, follow_latest=True).save("handover", str(path))


def screenshot(recording: Path, output: Path, size: str = "1600x1000") -> tuple[int, int]:
    """Write a PNG of `recording`'s end in the viewer to `output` (replaced); returns the
    picture's (width, height) in pixels (the window at the display's scale).

    Raises:
        RecorderError: a bad path or size (nothing written).
        HeadlessViewerError: Xvfb or software Vulkan missing, or the display, the compaction or
            the viewer failed (nothing written).
    """
    from PIL import Image

    width, height = parse_size(size)
    check_paths(recording, output)
    reason = missing()
    if reason is not None:
        raise HeadlessViewerError(f"the headless Rerun viewer cannot run here: {reason}")
    binary = viewer_binary()
    with tempfile.TemporaryDirectory(prefix="handover-screenshot-") as tmp:
        work = Path(tmp)
        layout, compact, picture = work / "handover.rbl", work / "compact.rrd", work / "screenshot.png"
        _layout(recording, layout)
        env = private_env(work)  # every rerun run here: analytics off, nothing sent off the machine
        _run([str(binary), "rrd", "optimize", str(recording), "-o", str(compact)], "rerun rrd optimize",
             OPTIMIZE_TIMEOUT_S, env=env)
        with headless_display(work, f"{width * 2}x{height * 2}x24") as display:
            _run([str(binary), "--bind", "127.0.0.1", "--port", "auto", "--window-size", f"{width}x{height}",
                  "--screenshot-to", str(picture), str(compact), str(layout)],
                 "the Rerun viewer", VIEWER_TIMEOUT_S, env=on_display(env, display))
        if not picture.is_file() or picture.stat().st_size == 0:
            raise HeadlessViewerError("the Rerun viewer exited without writing its screenshot")
        with Image.open(picture) as image:
            drawn = image.size
        try:
            shutil.copyfile(picture, output)
        except OSError as exc:
            raise RecorderError(f"--output {output}: {exc.strerror or exc}") from None
    return drawn
