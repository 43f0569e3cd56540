"""Shared command-line plumbing: common flags, logging, one-line errors, exit codes.

Exit codes: 0 success (including Ctrl-C), 1 the service failed while running, 2 bad input
(arguments, profile, config) — always with a one-line reason on stderr.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable

from services.runtime.allocator import keep_freed_memory
from services.runtime.errors import ServiceError
from services.runtime.logs import setup_logging, write_line
from services.runtime.profile import DEFAULT_PROFILE, Profile, load_profile_file
from services.runtime.zenoh_threads import use_one_zenoh_thread

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_BAD_INPUT = 2
#: A one-shot command stopped by Ctrl-C (128 + SIGINT, as a shell reports it).
EXIT_INTERRUPTED = 130


class _Parser(argparse.ArgumentParser):
    """argparse that reports errors as one line and exit code 2.

    With subcommands, argparse takes the value of an option it does not know for the
    subcommand (``handover-motion --replay x``: "invalid choice: 'x'"); such an error names
    the unknown option instead."""

    _args: list[str] = []

    def parse_known_args(self, args=None, namespace=None):
        self._args = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(args, namespace)

    def error(self, message: str) -> None:  # type: ignore[override]
        if "invalid choice" in message:
            unknown = [a for a in self._args if a.startswith("-") and a not in ("-", "--") and not self._knows(a)]
            if unknown:
                message = f"unrecognized option{'s' if len(unknown) > 1 else ''}: {' '.join(unknown)}"
        sys.stderr.write(f"{self.prog}: error: {message} (see --help)\n")
        raise SystemExit(EXIT_BAD_INPUT)

    def _knows(self, arg: str) -> bool:
        """True when `arg` is (or abbreviates) an option of this parser or of a subcommand."""
        name = arg.split("=", 1)[0]
        parsers = [self]
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                parsers.extend(action.choices.values())
        return any(option.startswith(name) for p in parsers for option in p._option_string_actions)


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Adds ``(default: X)`` to an option's help, but not when the help already says what the
    default is, nor when there is no default to show (None, or an off switch)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        help_text = action.help or ""
        if "default" in help_text.lower() or action.default in (None, False, argparse.SUPPRESS):
            return help_text
        return super()._get_help_string(action)


def one_line_parser(**kwargs) -> argparse.ArgumentParser:
    """An `argparse.ArgumentParser` (same arguments) whose errors are one line and exit 2."""
    return _Parser(**kwargs)


def base_parser(prog: str, description: str) -> argparse.ArgumentParser:
    """An argument parser with the flags every service shares.

    Flags: ``--profile`` (name under deploy/ or a TOML path, default ``sim``), ``--endpoint``
    (override the bus endpoint), ``--prefix`` (override the key prefix), ``--log-level``,
    ``--log-json``.
    """
    parser = _Parser(prog=prog, description=description,
                     formatter_class=HelpFormatter)
    group = parser.add_argument_group("bus and logging")
    group.add_argument("--profile", "--config", dest="profile", default=DEFAULT_PROFILE,
                       help="deploy profile: a name under deploy/ (sim, …) or a path to a TOML file")
    group.add_argument("--endpoint", default=None,
                       help="Zenoh router endpoint to connect to, e.g. tcp/127.0.0.1:7447 (overrides the profile)")
    group.add_argument("--prefix", default=None,
                       help="key prefix on the bus, e.g. handover/v1 (overrides the profile)")
    group.add_argument("--log-level", default="info", choices=["debug", "info", "warning", "error"],
                       help="log verbosity")
    group.add_argument("--log-json", action="store_true", help="log JSON lines instead of text")
    parser.set_defaults(service_name=prog.removeprefix("handover-"))
    return parser


def load_profile(args: argparse.Namespace) -> Profile:
    """The profile named by ``--profile`` with ``--endpoint``/``--prefix`` applied; its arm
    (``[robot]``, or ``HANDOVER_ROBOT``) becomes this process's (`handover_model.robots.use`)."""
    profile = load_profile_file(args.profile)
    use_profile_robot(profile)
    return profile.with_bus(getattr(args, "endpoint", None), getattr(args, "prefix", None))


def use_profile_robot(profile: Profile):
    """Make the profile's arm this process's and return its description.

    Raises:
        ProfileError: ``[robot]`` names an unknown model or holds a bad value.
    """
    from handover_model import robots
    from services.runtime.errors import ProfileError

    try:
        return robots.use(robots.from_profile(profile.raw, str(profile.path)))
    except robots.RobotDescriptionError as exc:
        raise ProfileError(str(exc)) from None


def run_main(run: Callable[[argparse.Namespace], int], args: argparse.Namespace,
             service: str | None = None) -> int:
    """Run a service's `run(args)` with logging set up and errors turned into exit codes.

    Ctrl-C ends a service normally (exit 0: the way to stop it), but interrupts a one-shot
    subcommand (``args.command`` other than ``run``: ``inspect``, ``screenshot``, ``offline``, …):
    one line and exit 130, so that a script does not take it for done."""
    name = service or getattr(args, "service_name", None) or "handover"
    use_one_zenoh_thread()  # before this process's first Zenoh session
    keep_freed_memory()
    setup_logging(name, getattr(args, "log_level", "info"), getattr(args, "log_json", False))
    log = logging.getLogger(name)
    try:
        return int(run(args) or 0)
    except KeyboardInterrupt:
        command = getattr(args, "command", None)
        if command in (None, "run"):
            return EXIT_OK
        write_line(f"{name} {command}: interrupted", flush_s=1.0)
        return EXIT_INTERRUPTED
    except ServiceError as exc:
        write_line(f"{name}: error: {exc}", flush_s=1.0)
        return EXIT_BAD_INPUT if is_input_error(exc) else EXIT_FAILURE
    except Exception as exc:  # a bug: say so in one line, details in the debug log
        log.debug("unhandled exception", exc_info=True)
        write_line(f"{name}: internal error: {type(exc).__name__}: {exc}", flush_s=1.0)
        return EXIT_FAILURE


def bounded_int(low: int, high: int | None = None) -> Callable[[str], int]:
    """An argparse type: a whole number within [`low`, `high`] (no upper bound when `high` is
    None); a one-line usage error otherwise."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"{value} must be >= {low}" if high is None
                                             else f"{value} must be within {low}–{high}")
        return value

    return parse


def bounded_float(low: float, high: float, unit: str = "") -> Callable[[str], float]:
    """An argparse type: a number within [`low`, `high`] (`unit`, e.g. " N", is printed after
    the numbers); a one-line usage error otherwise."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not low <= value <= high:  # NaN fails too
            raise argparse.ArgumentTypeError(f"{value:g}{unit} must be within {low:g}–{high:g}{unit}")
        return value

    return parse


def bounded_seconds(low_s: float, high_s: float) -> Callable[[str], float]:
    """An argparse type: a duration in seconds within [`low_s`, `high_s`]; a one-line usage
    error otherwise."""
    return bounded_float(low_s, high_s, " s")


#: An argparse type: a whole number >= 1.
positive_int = bounded_int(1)


def is_input_error(exc: ServiceError) -> bool:
    """Whether `exc` says the input was bad (exit 2) rather than the run failing (exit 1)."""
    from services.runtime.errors import ProfileError

    return isinstance(exc, ProfileError) or getattr(exc, "bad_input", False)



def run_subcommand(prog: str, args: argparse.Namespace, interrupted_hint: str = "") -> int:
    """Run an offline tool's subcommand (``args.func(args)``; ``args.command`` names it) with
    the tools' one error policy: a `ServiceError` is one line and exit 2 (bad input) or 1, an
    `OSError` one line and exit 1, Ctrl-C one line (with `interrupted_hint`) and exit 130."""
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print(f"{prog} {args.command}: interrupted{interrupted_hint}", file=sys.stderr)
        return 130
    except ServiceError as exc:
        print(f"{prog} {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT if is_input_error(exc) else EXIT_FAILURE
    except OSError as exc:
        print(f"{prog} {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_FAILURE
