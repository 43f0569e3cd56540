"""Per-run bus logins: `handover-up` on one host authenticates every session (issue 17).

With ``[bus] logins = "per-run"`` (the default simulation profile) the launcher, before it
starts the router:

- makes a private folder beside the recording, ``<recording dir>/handover-<run id>-bus/``
  (mode 700), with a random password per user (`secrets`): one file ``credentials`` with every
  ``user:password`` line (the router's dictionary) and one file per user with its own line
  (mode 600 each);
- starts the router with that dictionary and a deny-by-default access control list
  (`run_access_control`): each service may publish only the keys of `PUBLISHES` (its own
  heartbeat and liveliness token come with every login), and subscribe to every key (the ROS 1 ones too);
  the launcher itself reads what its job follows and may send a protective stop (it stops the
  arm when the supervisor falls silent); ``observer`` may only subscribe;
- hands each service its own file through ``HANDOVER_BUS_CREDENTIALS``;
- removes the folder when it exits.

A process outside the stack has no password: the router refuses its session. To run one
service by hand against a running stack, or to watch it, point ``HANDOVER_BUS_CREDENTIALS``
at that service's file (or ``observer``) in the run's ``-bus`` folder (docs/security.md).
"""

from __future__ import annotations

import os
import secrets
import shutil
import tempfile
import time
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path

from bus_schema import topics as T
from services.runtime.errors import ServiceError
from services.runtime.paths import write_new_file
from services.runtime.bus_access import CREDENTIALS_ENV, AccessControl, BusAuth, UserPermissions
from services.runtime.profile import Profile

#: The login of a process that only watches the bus (tests, tools): subscribe only.
OBSERVER = "observer"
#: The launcher's own login (its jobs follow the episodes).
LAUNCHER = "launcher"

#: Keys (topic suffixes) each service of a simulation profile may publish, besides its own
#: heartbeat and liveliness token. The tracker renders the simulated Kinect in its process
#: (``sensor = "sim"``), so it publishes the camera's streams too.
PUBLISHES: dict[str, tuple[T.Topic, ...]] = {
    "bridge": (T.JOINT_STATE, T.WRIST_WRENCH, T.OBJECT_MOTION, T.SIM_TRUTH, T.CLOCK, T.MOTION_STOP),
    "tracker": (T.HUMAN, T.OBJECT, T.SKELETON, T.DEPTH, T.KINECT_TRUTH),
    "kinect": (T.SKELETON, T.DEPTH, T.KINECT_TRUTH),
    "motion": (T.JOINT_COMMAND, T.MOTION_STATUS),
    "gripper": (T.GRIPPER_COMMAND, T.GRIPPER_STATE, T.GRIPPER_RELEASE),
    "supervisor": (T.MOTION_GOAL, T.MOTION_STOP, T.SUPERVISOR_STATE, T.EPISODE),
    "planner": (T.TRANSFER,),
    "recorder": (),
    "fake_baxter": (T.SKELETON, T.DEPTH, T.SIM_TRUTH, T.KINECT_TRUTH),  # it plays the Kinect driver too
    "franka_sim": (),  # franky-sim: the robot speaks libfranka's protocol, not the bus
}

#: The services that answer the simulation clock (`services.runtime.clock`), each on its own
#: ``sim/clock_ready/<name>``; the bridge grants the steps, the recorder and the launcher only
#: follow.
CLOCK_PARTICIPANTS = ("tracker", "kinect", "motion", "gripper", "supervisor", "planner")

#: ROS 1 keys (zenoh-bridge-ros1's ``<type>/<md5>/<topic>``, any namespace or key format:
#: ``**``) for the Baxter profiles: the bridge's Baxter backend sends the robot's commands, the
#: fake Baxter (robot, sensors and zenoh-bridge-ros1 in one process) its state and sensors,
#: and as the fake OpenNI camera openni_tracker's ``/tf`` and the depth camera's topics.
ROS_PUBLISHES: dict[str, tuple[str, ...]] = {
    "bridge": ("**/robot/limb/right/joint_command", "**/robot/limb/right/joint_command_timeout",
               "**/robot/set_super_enable", "**/robot/end_effector/right_gripper/command"),
    "fake_baxter": ("**/robot/joint_states", "**/robot/state", "**/handover/wrist_wrench",
                    "**/handover/optical_motion", "**/tf", "**/camera/depth/image_raw",
                    "**/camera/depth/camera_info"),
}

#: The file of the router's dictionary (every user) in the run's folder.
DICTIONARY = "credentials"


class LoginsError(ServiceError):
    """The per-run logins cannot be made (the message says what to check)."""


class LoginsProfileError(LoginsError):
    """The profile asks for per-run logins the launcher cannot make: a usage error (exit 2)."""

    bad_input = True


@dataclass(frozen=True)
class RunLogins:
    """The files of one run's logins (see the module docstring)."""

    directory: Path

    @property
    def dictionary(self) -> Path:
        return self.directory / DICTIONARY

    def user_file(self, user: str) -> Path:
        """The file holding only `user`'s ``user:password`` line."""
        return self.directory / user

    def remove(self) -> None:
        shutil.rmtree(self.directory, ignore_errors=True)


def remove_logins(logins: RunLogins | None) -> None:
    """Delete a run's logins folder (nothing when the run has none)."""
    if logins is not None:
        logins.remove()


def logins_dir(recording_dir: Path, run_id: str) -> Path:
    """The run's logins folder, beside its recording and its logs."""
    return recording_dir / f"handover-{run_id}-bus"


def create_run_logins(directory: Path, users: Iterable[str]) -> RunLogins:
    """Make `directory` (mode 700, must not exist) with a random password for each of `users`.
    The files are written in a private folder beside it, renamed into place once complete: a
    reader never sees a half-written login, and a failure leaves nothing behind.

    Raises:
        LoginsError: the folder exists already or cannot be written.
    """
    if directory.exists():
        raise LoginsError(f"the bus logins folder {directory} exists already (another run with this --run-id, "
                          "or one killed before it could delete it: remove the folder)")
    staging: Path | None = None
    try:
        directory.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{directory.name}-", dir=directory.parent))  # mode 700
        passwords = {user: secrets.token_urlsafe(24) for user in sorted(set(users))}
        for user, password in passwords.items():
            write_new_file(staging / user, f"{user}:{password}\n".encode(), private=True)
        write_new_file(staging / DICTIONARY, "".join(f"{u}:{p}\n" for u, p in passwords.items()).encode(),
                       private=True)
        os.rename(staging, directory)
    except OSError as exc:
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)
        raise LoginsError(f"cannot write the bus logins folder {directory}: {exc.strerror or exc}") from None
    return RunLogins(directory)


#: Keys a service publishes only in some set-ups: the tracker renders the Kinect only with
#: ``sensor = "sim"`` (with ``"ros1"`` it publishes the skeleton and depth it converts, but no
#: Kinect truth), the bridge runs the simulation (and its truth) only with the sim backend.
_SIM_ONLY: dict[str, tuple[T.Topic, ...]] = {"tracker": (T.SKELETON, T.DEPTH, T.KINECT_TRUTH),
                                             "bridge": (T.SIM_TRUTH, T.CLOCK)}


def _unused(name: str, profile: Profile | None) -> tuple[T.Topic, ...]:
    """The `_SIM_ONLY` keys `name`'s set-up in `profile` does not publish (no profile: none)."""
    if profile is None:
        return ()
    from services.bridge.config import BridgeConfig
    from services.tracker.config import TrackerConfig

    config = profile.service_config(name)
    if name == "tracker":
        sensor = config.get("sensor", TrackerConfig().sensor)  # the tracker's own default
        return {"sim": (), "ros1": (T.KINECT_TRUTH,)}.get(sensor, _SIM_ONLY["tracker"])
    return () if config.get("backend", BridgeConfig().backend) == "sim" else _SIM_ONLY.get(name, ())


def run_access_control(services: Iterable[str], job: str, profile: Profile | None = None) -> AccessControl:
    """The router's deny-by-default list for one run of `services` with `job` (each service's
    keys as `profile` sets it up, when given).

    Raises:
        LoginsError: a service whose keys are not known (not in `PUBLISHES`).
    """
    everything = ("**",)  # the prefix's keys and, for the Baxter profiles, the ROS 1 ones
    users: dict[str, UserPermissions] = {}
    for name in services:
        if name not in PUBLISHES:
            raise LoginsProfileError(f"service {name!r} has no known keys for per-run bus logins "
                                     f"(services.launcher.logins.PUBLISHES knows {', '.join(sorted(PUBLISHES))}); "
                                     "give the profile fixed logins and an access list ([bus.auth], "
                                     "[bus.access_control]) instead")
        unused = _unused(name, profile)
        own = (tuple(f"{{prefix}}/{t.suffix}" for t in PUBLISHES[name] if t not in unused)
               + ROS_PUBLISHES.get(name, ())
               + (("{prefix}/sim/clock/*",) if T.CLOCK in PUBLISHES[name] and T.CLOCK not in unused else ())
               + ((T.CLOCK_READY.sender_key(name, "{prefix}"),) if name in CLOCK_PARTICIPANTS else ()))
        users[name] = UserPermissions(publish=own, subscribe=everything)
    follows = (T.SUPERVISOR_STATE, T.EPISODE, T.SIM_TRUTH, T.JOINT_STATE)
    # The job stops the arm itself when the supervisor falls silent; the demo drives the arm.
    publish = (T.MOTION_STOP, T.JOINT_COMMAND) if job == "demo" else (T.MOTION_STOP,)
    users[LAUNCHER] = UserPermissions(publish=tuple(f"{{prefix}}/{t.suffix}" for t in publish),
                                      subscribe=tuple(f"{{prefix}}/{t.suffix}" for t in follows))
    users[OBSERVER] = UserPermissions(subscribe=everything)
    return AccessControl("deny", users)


def start_run_logins(profile: Profile, services: list[str], recording_dir: Path, run_id: str,
                     job: str) -> tuple[RunLogins | None, Profile, AccessControl | None]:
    """For a ``logins = "per-run"`` profile: the run's logins, the profile the launcher's own
    sessions use (authenticated as any user of the dictionary) and the router's ACL. Otherwise
    (None, `profile`, its own ACL)."""
    if profile.logins != "per-run":
        return None, profile, profile.access_control
    acl = run_access_control(services, job, profile)  # refuses an unknown service before any file is made
    logins = create_run_logins(logins_dir(recording_dir, run_id), [*services, LAUNCHER, OBSERVER])
    # The run's own dictionary, whatever HANDOVER_BUS_CREDENTIALS says in the launcher's environment.
    return logins, replace(profile, auth=BusAuth(logins.dictionary, env_override=False)), acl


def child_env(logins: RunLogins | None, service: str) -> dict[str, str]:
    """The environment that hands `service` its own login (nothing without per-run logins)."""
    return {} if logins is None else {CREDENTIALS_ENV: str(logins.user_file(service))}


def login_profile(profile: Profile, recording_dir: Path, run_id: str, user: str = OBSERVER,
                  timeout_s: float = 30.0) -> Profile:
    """`profile` (a ``logins = "per-run"`` one) with login `user` of the run `run_id` whose
    recording goes to `recording_dir`, once `handover-up` has made it (for tests and tools
    that watch a running stack, or act as one of its services). Another profile comes back
    as it is.

    Raises:
        LoginsError: the login did not appear within `timeout_s`.
    """
    if profile.logins != "per-run":
        return profile
    path = logins_dir(recording_dir, run_id) / user
    deadline = time.monotonic() + timeout_s
    while not path.is_file():
        if time.monotonic() > deadline:
            raise LoginsError(f"no bus login {path} after {timeout_s:.0f} s (is handover-up running that run?)")
        time.sleep(0.05)
    return replace(profile, auth=BusAuth(path))


def bus_line(profile: Profile, router_pid: int, logins_folder: Path | None) -> str:
    """The launcher's first line: where the bus is and who may use it."""
    where = "other hosts allowed" if profile.allow_non_loopback else "loopback only"
    guard = (f"logins in {logins_folder}/" if logins_folder is not None else "fixed logins" if profile.auth
             else "NO LOGINS: any local process may publish")
    return f"bus on {profile.endpoint} (router pid {router_pid}, {where}, prefix {profile.prefix}, {guard})"
