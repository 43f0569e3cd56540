"""`handover-up`: start the whole stack from a deploy profile and run a job."""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from handover_model import robots
from handover_model.robots import ROBOT_ENV
from services.launcher.checks import check_niced_services_are_report_only, clock_environment
from services.launcher.core import JOBS, LaunchOptions, check_one_simulated_kinect, job_services
from services.launcher.errors import LauncherUsageError
from services.launcher.node import Launcher
from services.launcher.processes import DEFAULT_OUTPUT_QUEUE_LINES, stdout_outlet
from services.runtime import base_parser, load_profile_file, run_main
from services.runtime.cli import use_profile_robot
from services.runtime.errors import ProfileError
from services.runtime.profile import free_tcp_port


def _route_own_logs(verbose: bool) -> None:
    """The launcher's own log records: into ``launcher.log``, and as `[launcher]` lines on the
    console when `verbose` or at WARNING and above (never blocking)."""
    import logging

    from services.launcher.logfiles import own_line
    from services.launcher.processes import emit

    class _Prefixed(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            own_line(record.getMessage(), record.levelname)
            if verbose or record.levelno >= logging.WARNING:
                emit(f"[launcher] {record.getMessage()}\n")

    logging.getLogger().handlers[:] = [_Prefixed()]


def _check_recording_dir(directory: Path) -> None:
    """Refuse a recording folder that cannot be created or written before any service starts
    (the recorder would otherwise fail, be restarted and fail again mid-run; the logs go there
    too)."""
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=directory):
            pass
    except OSError as exc:
        raise LauncherUsageError(f"--recording-dir {str(directory)!r}: cannot write a recording there "
                            f"({exc.strerror or exc}); choose a writable folder") from None


def _run(args: argparse.Namespace) -> int:
    profile = load_profile_file(args.profile)
    endpoint = args.endpoint
    if args.port is not None:
        scheme = "tls" if profile.tls is not None else "tcp"  # a TLS profile stays TLS on another port
        if args.port == "auto":
            endpoint = f"{scheme}/127.0.0.1:{free_tcp_port()}"
        elif args.port.isdigit() and 0 < int(args.port) < 65536:
            endpoint = f"{scheme}/127.0.0.1:{int(args.port)}"
        else:
            raise LauncherUsageError(f"--port {args.port!r} must be a port number 1–65535 or 'auto'")
    profile = profile.with_bus(endpoint, args.prefix)
    if args.robot is not None:
        os.environ[ROBOT_ENV] = args.robot  # every service inherits it (handover_model.robots)
    robot = use_profile_robot(profile)
    os.environ[ROBOT_ENV] = robot.name
    check_one_simulated_kinect(profile)
    check_niced_services_are_report_only(profile)
    cfg = profile.launcher
    options = LaunchOptions(
        job=args.job or str(cfg.get("job", "handover")),
        run_id=args.run_id or time.strftime("%Y%m%d-%H%M%S"),
        recording_dir=Path(args.recording_dir or cfg.get("recording_dir", "recordings")),
        alive_timeout_s=float(args.alive_timeout_s if args.alive_timeout_s is not None
                              else cfg.get("alive_timeout_s", 30.0)),
        term_timeout_s=float(cfg.get("term_timeout_s", 5.0)),
        receiver=args.receiver,
        posture=args.posture,
        episodes=args.episodes,
        seed=args.seed,
        episode_timeout_s=float(cfg.get("episode_timeout_s", 90.0)),
        verbose=args.verbose,
    )
    if options.episodes is not None and not 0 <= options.episodes <= 100000:
        raise LauncherUsageError("--episodes must be within 0–100000 (0: until Ctrl-C)")
    if options.seed is not None and not 0 <= options.seed < 2**32:
        raise LauncherUsageError("--seed must be within 0–4294967295")
    if not 0 < options.alive_timeout_s <= 600:
        raise LauncherUsageError("--alive-timeout-s must be within (0, 600] s")
    queue_lines = cfg.get("output_queue_lines", DEFAULT_OUTPUT_QUEUE_LINES)
    if isinstance(queue_lines, bool) or not isinstance(queue_lines, int) or not 1 <= queue_lines <= 1_000_000:
        raise ProfileError(f"{profile.path}: launcher.output_queue_lines {queue_lines!r} must be an "
                           "integer within 1–1000000")
    started = [s.name for s in job_services(profile.services, options.job)]
    clock_env = clock_environment(profile, args.clock, options.job, started)
    _check_recording_dir(options.recording_dir)  # last: it makes the folder (bad input changes nothing)
    stdout_outlet(queue_lines)  # before the first line, so the bound holds from the start
    _route_own_logs(options.verbose)
    os.environ.update(clock_env)  # the services inherit it, and the launcher's own bus node follows it
    return Launcher(profile, options).run()


def main(argv: list[str] | None = None) -> int:
    parser = base_parser(
        "handover-up",
        "Start the handover stack from a deploy profile: host the Zenoh router on loopback, start "
        "every service, wait until all are alive, run a job, and shut everything down in order on "
        "Ctrl-C. Leaves one Rerun recording per run and, beside it, a folder with every service's "
        "log. The console shows the launcher's progress, the services' warnings and errors, and "
        "the summary.",
    )
    parser.add_argument("--job", choices=JOBS, default=None,
                        help="handover: run the supervisor's handover episodes and print a summary "
                             "(default); demo: joint-space demo; check: exit once all services are "
                             "alive; none: run until Ctrl-C")
    scene = parser.add_argument_group("the simulated handover (sim profile)")
    scene.add_argument("--receiver", choices=["taking", "dropping", "bumping", "hesitating", "absent"],
                       default=None, help="the receiver's behaviour (default: the profile's, taking)")
    scene.add_argument("--robot", choices=sorted(robots.BUILTIN), default=None,
                       help="the arm (default: the profile's [robot] model); docs/robots.md")
    scene.add_argument("--posture", choices=["standing", "sitting"], default=None,
                       help="the receiver's posture (default: the profile's, standing)")
    scene.add_argument("--episodes", type=int, default=None,
                       help="handover episodes to run (default: the profile's, 1; 0: until Ctrl-C)")
    scene.add_argument("--seed", type=int, default=None, help="seed of the simulation's noise")
    scene.add_argument("--clock", choices=["wall", "sim"], default=None,
                       help="sim: the simulation owns time, the stack runs as fast as its slowest "
                            "service allows and a seed repeats the run step for step; wall: real time "
                            "(default: the profile's [clock] source, wall)")
    parser.add_argument("--port", default=None,
                        help="bus port on 127.0.0.1, or 'auto' for a free one (overrides --endpoint)")
    parser.add_argument("--run-id", default=None, help="name of this run (default: the start time)")
    parser.add_argument("--recording-dir", default=None,
                        help="where the recording and the folder of logs go (default: recordings/)")
    parser.add_argument("-v", "--verbose", action="store_true",
                        help="print every line of every service on the console as well, prefixed "
                             "[name] (they are always in the log folder)")
    parser.add_argument("--alive-timeout-s", type=float, default=None,
                        help="how long every service may take to come up (default: the profile's, 30 s)")
    parser.set_defaults(service_name="handover-up")
    return run_main(_run, parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
