"""One evaluation episode: a whole stack (`handover-up`) in a subprocess, and its record.

Each episode gets its own folder ``<run>/episodes/eNNNN/`` with its profile (the base profile
with the episode's draw, `episode_profile`), its recording and service logs (the launcher's
``--recording-dir``), the launcher's console (``console.txt``) and its record
(``record.json``, written last, atomically: an episode with a record is done, and
`run_episode` returns that record again without running it, which makes a run resumable
even without the engine's checkpoint). The launcher hosts its own bus on a free loopback port
(``--port auto``) and makes the run's own logins; nothing is shared between episodes.

`launcher_command` is the one place where the launcher's command line is built.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from services.launcher.logins import logins_dir
from handover_model import robots
from handover_model.robots import RobotDescription
from services.runtime.profile import REPO_ROOT
from services.studies.evaluation.djt_reference import djt_optimum_base_m
from services.studies.evaluation.episode_profile import episode_table, read_base_profile, write_episode_profile
from services.studies.evaluation.errors import EvaluationError
from services.studies.evaluation.population import EpisodeDraw, draw_episode
from services.studies.evaluation.record import NO_SUMMARY, episode_record
from services.studies.evaluation.recording import read_episode_recording

#: The record of an episode whose stack gave no readable recording.
STACK_ERROR = "stack_error"
#: After SIGINT at the time-out, how long the launcher may take to stop its stack, s (the
#: recorder finalises its file on the way).
STOP_GRACE_S = 90.0


@dataclass(frozen=True)
class EpisodeTask:
    """What one episode needs (picklable: it may run on another machine with the same files).

    Attributes:
        run_dir: the run's folder.
        episode: 0-based episode index.
        run_seed: the population's seed.
        base_profile: the base profile (path).
        timeout_s: the episode's stack is stopped after this long, s.
        clock: the stack's clock, ``sim`` (the simulation's: as fast as the machine allows,
            the same episode for the same seed) or ``wall``.
        robot: the arm (`handover_model.robots.BUILTIN` name) written into every episode's
            profile; None: the base profile's.
    """

    run_dir: str
    episode: int
    run_seed: int
    base_profile: str
    timeout_s: float = 240.0
    clock: str = "sim"
    robot: str | None = None


def episode_dir(run_dir: Path, episode: int) -> Path:
    return Path(run_dir) / "episodes" / f"e{episode:04d}"


def run_id(episode: int) -> str:
    """The launcher's run id of an episode (names its recording ``handover-<id>.rrd``)."""
    return f"e{episode:04d}"


def recording_file(folder: Path, episode: int) -> Path:
    return folder / f"handover-{run_id(episode)}.rrd"


def launcher_command(profile: Path, folder: Path, episode: int, clock: str = "sim") -> list[str]:
    """The command line of one episode's stack: the launcher with the episode's profile, a
    free loopback port, the episode's run id and folder, on `clock` (``sim`` or ``wall``)."""
    return [sys.executable, "-m", "services.launcher", "--profile", str(profile), "--port", "auto",
            "--run-id", run_id(episode), "--recording-dir", str(folder), "--job", "handover", "--episodes", "1",
            "--clock", clock]


def _environment() -> dict[str, str]:
    """This process's environment with this code's root first on PYTHONPATH, so that the
    launcher and its services import the same code as the evaluation."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO_ROOT), env.get("PYTHONPATH", "")) if p)
    return env


@contextlib.contextmanager
def episode_lock(folder: Path) -> Iterator[int]:
    """Hold the episode folder's lock (``.episode.lock``, `flock`) for as long as this block and
    any process the lock's file descriptor (yielded) is passed to run. An attempt whose worker
    died leaves its launcher running with the descriptor: a second attempt (the engine runs the
    task again elsewhere) waits here until that stack has ended instead of running beside it
    into the same folder."""
    fd = os.open(folder / ".episode.lock", os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield fd
    finally:
        os.close(fd)


def run_stack(command: list[str], console: Path, timeout_s: float, keep_fds: tuple[int, ...] = ()) -> tuple[int, bool]:
    """Run `command` (the launcher) with its output into `console`; (exit code, timed out).
    At the time-out the launcher gets SIGINT (it stops its stack in order), then SIGKILL
    after `STOP_GRACE_S` (its services get SIGTERM from the kernel when it dies). `keep_fds`:
    descriptors the launcher inherits (the episode's lock)."""
    with console.open("wb") as out:
        proc = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, env=_environment(),
                                cwd=str(console.parent), start_new_session=True, pass_fds=keep_fds)
        try:
            return proc.wait(timeout=timeout_s), False
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGINT)
            try:
                return proc.wait(timeout=STOP_GRACE_S), True
            except subprocess.TimeoutExpired:
                proc.kill()
                return proc.wait(), True
        except BaseException:
            proc.kill()  # interrupted: never leave a stack behind
            proc.wait()
            raise


def _stack_error_record(draw: EpisodeDraw, exit_code: int, wall_s: float, error: str) -> dict[str, Any]:
    return {"episode": draw.episode, "seed": draw.sim_seed, "draw": draw.as_dict(), "behaviour": draw.behaviour,
            "posture": draw.posture, "height_m": draw.height_m, "exit_code": exit_code, "wall_s": wall_s,
            "outcome": STACK_ERROR, "reason": error, "success": False, "dropped": False, "criteria": {}}


def write_json(path: Path, data: dict[str, Any]) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=True))
    os.replace(tmp, path)


def read_record(run_dir: Path, episode: int) -> dict[str, Any] | None:
    """The episode's record when it is done (None when it has none yet, or an unreadable one)."""
    path = episode_dir(run_dir, episode) / "record.json"
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def run_and_record(folder: Path, profile: Path, draw: EpisodeDraw, planner_config: dict[str, Any],
                   timeout_s: float, clock: str = "sim", keep_fds: tuple[int, ...] = (),
                   robot: RobotDescription | None = None) -> dict[str, Any]:
    """Run the stack of `profile` (the episode of `draw`) with its output in `folder`; the
    record read from its recording (``record.json`` is written by the caller). `keep_fds`:
    descriptors the launcher inherits (the episode's lock); `robot`: the profile's arm (the DJT
    reference's giver; None: the default arm's)."""
    t0 = time.monotonic()
    command = launcher_command(profile, folder, draw.episode, clock)
    code, timed_out = run_stack(command, folder / "console.txt", timeout_s, keep_fds)
    wall_s = time.monotonic() - t0
    recording = recording_file(folder, draw.episode)
    try:
        rec = read_episode_recording(recording)
    except EvaluationError as exc:
        record = _stack_error_record(draw, code, wall_s, f"{exc} (see {folder / 'console.txt'})")
    else:
        record = episode_record(draw, rec, djt_optimum_base_m(draw, planner_config, robot), code, wall_s)
        if record["outcome"] == NO_SUMMARY:
            record["reason"] = ("timed out" if timed_out else f"launcher exit {code}") + \
                f": no episode summary (see {folder / 'console.txt'})"
    record["timed_out"] = timed_out
    record["recording"] = str(recording)
    return record


def planner_config(base: dict[str, Any]) -> dict[str, Any]:
    """The base profile's ``[services.planner.config]`` (empty when it has none)."""
    return base["services"].get("planner", {}).get("config", {})


def run_episode(task: EpisodeTask) -> dict[str, Any]:
    """Run one episode (or return its record when it is already done); its record."""
    run_dir = Path(task.run_dir)
    done = read_record(run_dir, task.episode)
    if done is not None:
        return done
    folder = episode_dir(run_dir, task.episode)
    folder.mkdir(parents=True, exist_ok=True)
    with episode_lock(folder) as lock_fd:
        done = read_record(run_dir, task.episode)  # another attempt finished it meanwhile
        if done is not None:
            return done
        # An attempt whose launcher was killed (Ctrl-C in `run_stack`, a worker's end) left its
        # logins folder, which its launcher deletes at any other exit; a launcher with the same
        # run id refuses to start beside it, and the episode would be recorded as a stack error.
        shutil.rmtree(logins_dir(folder, run_id(task.episode)), ignore_errors=True)
        _base_path, base = read_base_profile(task.base_profile)
        draw = draw_episode(task.run_seed, task.episode)
        profile = write_episode_profile(base, draw, folder / "profile.toml", task.robot)
        arm = robots.from_profile(episode_table(base, draw, task.robot), str(profile))
        record = run_and_record(folder, profile, draw, planner_config(base), task.timeout_s, task.clock, (lock_fd,),
                                arm)
        write_json(folder / "record.json", record)
    return record
