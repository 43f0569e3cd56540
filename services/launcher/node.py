"""`handover-up`: host the bus, start every service, run a job, shut down in order.

1. Start the Zenoh router as its own process on the profile's loopback endpoint
   (`services.launcher.router`), so that no Python work of the launcher sits on the bus's path.
2. Start the enabled services (recorder first) as child processes, each one's output into its
   log file beside the recording (`services.launcher.logfiles`); the console shows their
   warnings and errors, prefixed ``[name]`` (every line with ``--verbose``).
3. Wait for every liveliness token (time-out names the services that did not come up).
4. Run the job (``handover``: follow the supervisor's handover episodes and report them;
   ``demo``: joint-space demo; ``check``: stop once all are alive; ``none``: run until
   Ctrl-C, the supervisor's silence still watched as in ``handover``) while a monitor
   thread watches the children and their liveliness (it sleeps until a child exits, a token
   changes or a stop comes: `services.launcher.wakeup`).
5. Shut down in order: SIGINT, SIGTERM after `term_timeout_s`, SIGKILL after as long again.

Output (the children's, prefixed, and the launcher's own) never blocks the launcher: it waits
in a bounded queue for stdout (``[launcher] output_queue_lines`` of the profile, default 8192)
and in one for each log file; when one is blocked its oldest lines are dropped and their count
is written once it takes output again (`services.launcher.processes`).

Exit codes: 0 job succeeded; 1 a service failed or the job failed; 2 bad input (profile,
arguments, port in use); 130 interrupted by Ctrl-C/SIGTERM.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable
from pathlib import Path

from services.launcher.arm_stop import ArmStop
from services.launcher.bus_host import host_bus
from services.launcher.core import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    JOBS,
    RECORDER,
    LaunchOptions,
    decide_restart,
    describe_exit,
    final_exit_code,
    format_startup_times,
    job_services,
    logs_dir,
    recording_path,
    scene_service,
    service_command,
    shutdown_order,
)
from services.launcher.errors import LauncherError
from services.launcher.jobs import demo_job, handover_job, run_on_bus, supervisor_watch_job
from services.launcher.logfiles import LogFiles, own_line
from services.launcher.logins import RunLogins, bus_line, child_env
from services.launcher.precompile import precompile_stack
from services.launcher.processes import Child, RouterProcess, emit, stdout_outlet
from services.launcher.wakeup import MonitorWakeup, WakingEvent
from services.runtime import LivelinessWatcher, Profile
from services.runtime.sched import ROUTER_PID_ENV
from services.runtime.signals import SignalRelay

#: At exit, how long the launcher waits for a blocked stdout to take its last lines, s.
EXIT_FLUSH_S = 10.0


def say(text: str, console: bool = True) -> None:
    """One line of the launcher's own: into ``launcher.log``, and on the console unless not
    `console` (never blocks)."""
    own_line(text)
    if console:
        emit(f"[launcher] {text}\n")


class Launcher:
    """Runs one stack from a profile (see module docstring)."""

    def __init__(self, profile: Profile, options: LaunchOptions) -> None:
        if options.job not in JOBS:
            raise LauncherError(f"unknown job {options.job!r} (choose from {', '.join(JOBS)})")
        self.profile = profile
        self.options = options
        self.specs = job_services(profile.services, options.job)
        if not self.specs:
            raise LauncherError(f"profile {profile.path} enables no service")
        self.width = max(len("launcher"), *(len(s.name) for s in self.specs))
        self.children: dict[str, Child] = {}
        self.router_pid: int | None = None  # the watchers judge the delivery path's starvation too
        self.restarts: dict[str, int] = {s.name: 0 for s in self.specs}
        self.recording: Path | None = None
        self.logins: RunLogins | None = None  # per-run bus logins (services.launcher.logins)
        self.bus_profile = profile  # with the run's logins, for the launcher's own sessions
        self.logs = LogFiles(logs_dir(options.recording_dir, options.run_id))
        self.verbose = options.verbose
        #: What the monitor thread sleeps on: a child's exit, a liveliness change, a stop.
        self.wakeup = MonitorWakeup()
        self.stop_requested: threading.Event = WakingEvent(self.wakeup)
        self.failure: str | None = None
        #: The monitor's protective stop of the arm while a job runs on the bus.
        self.arm_stop = ArmStop()
        self.episode_running = False
        self.shutting_down = False
        self.interrupted = False
        #: SIGINT/SIGTERM, acted on in a thread of their own (`services.runtime.signals`).
        self._signals = SignalRelay(self._on_signal, name="launcher signals")
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ children
    def _extra_args(self, name: str, attempt: int) -> list[str]:
        if name == RECORDER:
            self.recording = recording_path(self.options.recording_dir, self.options.run_id, attempt)
            return ["--output", str(self.recording)]
        return self.options.service_args(name, scene_service(self.specs))

    def _start(self, name: str) -> Child:
        spec = next(s for s in self.specs if s.name == name)
        env = {**({ROUTER_PID_ENV: str(self.router_pid)} if self.router_pid else {}), **child_env(self.logins, name)}
        log = self.logs.outlet(name)  # None: no file, so every line goes to the console
        child = Child(name, service_command(spec, self.profile, self._extra_args(name, self.restarts[name])),
                      self.width, env=env or None, nice=spec.nice, log=log, verbose=self.verbose or log is None)
        child.start()
        self.children[name] = child
        if child.pid is not None:
            self.wakeup.watch(name, child.pid)
        return child

    def _fail(self, reason: str, stop_arm: bool = False) -> None:
        """Take `reason` as the run's failure (the first one counts) and say it; `stop_arm`:
        send the protective stop first (`ArmStop`: only while a job's node is open). The failure
        is recorded before the stop's put, which may wait on a full link: the job's loop sees it
        meanwhile and stops the arm itself."""
        with self._lock:
            if self.failure is None:
                self.failure = reason
        if stop_arm:
            self.arm_stop.send(reason)
        say(f"FAILURE: {reason}")

    def _monitor(self, watcher: LivelinessWatcher) -> None:
        seen_events = 0
        while not self.stop_requested.is_set():
            events = watcher.events()
            for _t, name, alive in events[seen_events:]:
                if not alive and not self.shutting_down and name in self.children:
                    say(f"{name} lost its liveliness token")
            seen_events = len(events)
            if not self.shutting_down:
                for name, child in list(self.children.items()):
                    code = child.poll()
                    if code is None:
                        continue
                    self.wakeup.forget(name)  # handled: its process file descriptor stays readable
                    spec = next(s for s in self.specs if s.name == name)
                    decision = decide_restart(spec, self.restarts[name], self.episode_running, code)
                    if decision.restart:
                        say(decision.reason)
                        self.restarts[name] += 1
                        self._start(name)
                    else:
                        del self.children[name]
                        self._fail(decision.reason, stop_arm=True)
                        self.stop_requested.set()
            for name in self.wakeup.exited():  # an exit no pass will handle must not wake it again
                if self.shutting_down or name not in self.children:
                    self.wakeup.forget(name)
            self.wakeup.wait()

    def _wait_alive(self, watcher: LivelinessWatcher, names: set[str] | None = None) -> float:
        names = names if names is not None else {s.name for s in self.specs}
        start = time.monotonic()
        deadline = start + self.options.alive_timeout_s
        while True:
            missing = names - watcher.alive()
            if not missing:
                return time.monotonic() - start
            for name in sorted(missing):
                code = self.children[name].poll() if name in self.children else None
                if code is not None:
                    raise LauncherError(f"{name} {describe_exit(code)} before it came up (see {self._output(name)})")
            if self.stop_requested.is_set():
                raise KeyboardInterrupt
            if time.monotonic() > deadline:
                raise LauncherError(
                    f"{', '.join(sorted(missing))} did not come up within {self.options.alive_timeout_s:.0f} s "
                    f"(no liveliness token under {self.profile.prefix}/alive/); see {self._output(*sorted(missing))}"
                )
            time.sleep(0.01)

    def _open_logs(self, router: RouterProcess) -> None:
        """Open the run's log files (once the bus is up: a stack that never starts leaves none);
        without them every line goes to the console."""
        if self.logs.open():
            router.log, router.verbose = self.logs.outlet("router"), self.verbose
        else:
            self.verbose = router.verbose = True
            say(f"no log files ({self.logs.error}): every service's output comes here")

    def _output(self, *names: str) -> str:
        """Where the output of services `names` is, for a line that sends the user there."""
        return "their output above" if self.verbose else ", ".join(str(self.logs.path(n)) for n in names)

    def _shutdown(self) -> None:
        """Stop the children in order; quiet, one line for those that ended as asked (SIGINT, 0)."""
        self.shutting_down = True
        t0, stopped, clean = time.monotonic(), 0, True
        for spec in shutdown_order(self.specs):
            child = self.children.get(spec.name)
            if child is None:
                continue
            code, how = child.stop(spec.stop_timeout_s or self.options.term_timeout_s)
            stopped, ok = stopped + 1, (code, how) == (0, "SIGINT")
            clean = clean and ok
            say(f"stopped {spec.name} (pid {child.pid}) with {how}: {describe_exit(code)}", self.verbose or not ok)
        if stopped and not self.verbose:
            say(f"{stopped} services stopped in {time.monotonic() - t0:.2f} s"
                + (" (each exited with code 0 on SIGINT)" if clean else ""))

    # ------------------------------------------------------------------ main
    def run(self) -> int:
        """Host the bus, start the services, run the job, shut down; the exit code."""
        self.interrupted = False
        self._signals.install()
        t0 = time.monotonic()
        precompile_stack()
        bus = host_bus(self.profile, [s.name for s in self.specs], self.options, self.width,
                       on_failure=self._signals.restore)
        self.logins, self.bus_profile, self.router_pid = bus.logins, bus.bus_profile, bus.router.pid
        watcher = LivelinessWatcher(bus.session, self.profile.prefix, on_change=lambda _n, _a: self.wakeup.wake())
        monitor: threading.Thread | None = None
        code = EXIT_FAILED
        try:
            monitor = self._start_services(bus.router, watcher, t0)
            code = self._run_job()
        except KeyboardInterrupt:
            code = EXIT_INTERRUPTED
        except LauncherError as exc:
            say(f"FAILURE: {exc}")
            code = EXIT_FAILED
        finally:
            self.stop_requested.set()
            if monitor is not None:
                monitor.join(timeout=2.0)
            self._shutdown()
            watcher.undeclare()
            bus.close()
            self._signals.restore()
            if monitor is None or not monitor.is_alive():  # one that outlived its join keeps its fds
                self.wakeup.close()
        return self._finish(code)

    def _on_signal(self, signum: int) -> None:
        """SIGINT/SIGTERM, in the relay's thread (never the handler: `say` and `set` take locks)."""
        first = not self.stop_requested.is_set()
        self.interrupted = True
        self.stop_requested.set()  # before the line: a failing write must not keep the stop from coming
        if first:
            say(f"{signal.Signals(signum).name} received: shutting down")

    def _start_services(self, router: RouterProcess, watcher: LivelinessWatcher, t0: float) -> threading.Thread:
        """Open the logs, start every service (the recorder alive first), wait until all are
        alive (`t0`: the launch, monotonic s); the monitor thread, started."""
        self._open_logs(router)
        say(bus_line(self.profile, router.pid, self.logins.directory if self.logins else None))
        if self.logs.error is None:
            say(f"logs of every service: {self.logs.directory}/"
                + ("" if self.verbose else " (--verbose prints them here too)"))
        for spec in self.specs:
            child = self._start(spec.name)
            effective = max(spec.nice, os.getpriority(os.PRIO_PROCESS, 0))  # never below the launcher's
            niceness = f" at nice {effective}" if effective else ""
            say(f"started {spec.name} (pid {child.pid}){niceness}: python -m {spec.module}")
            if spec.name == RECORDER:
                # Nothing may be published before the recorder listens.
                self._wait_alive(watcher, {RECORDER})
        alive_s = self._wait_alive(watcher)
        say(f"all {len(self.specs)} services alive {alive_s:.2f} s after start "
            f"({time.monotonic() - t0:.2f} s after launch)")
        say("start-up, spawn → alive: " + format_startup_times(
            {n: c.started_monotonic for n, c in self.children.items()}, watcher.events()))
        self.alive_after_s = time.monotonic() - t0
        monitor = threading.Thread(target=self._monitor, args=(watcher,), name="monitor", daemon=True)
        monitor.start()
        return monitor

    def _finish(self, job_code: int) -> int:
        """Say where the recording is and the exit code; flush the output; the exit code."""
        code = final_exit_code(job_code, self.failure, self.interrupted)
        if self.recording is not None and self.recording.exists():
            say(f"recording: {self.recording}  (open it with: rerun {self.recording})")
        say(f"exit {code}" + (f": {self.failure}" if self.failure else ""))
        stdout_outlet().flush(EXIT_FLUSH_S)  # a blocked stdout delays the exit this long at most
        self.logs.close()
        return code

    # ------------------------------------------------------------------ jobs
    def _abort_reason(self) -> str | None:
        if self.failure:
            return self.failure
        if self.stop_requested.is_set():
            return "interrupted"
        return None

    def _episodes(self) -> int:
        if self.options.episodes is not None:
            return self.options.episodes
        return int(self.profile.service_config("supervisor").get("episodes", 1))

    def _supervisor_pid(self) -> int | None:
        child = self.children.get("supervisor")
        return None if child is None else child.pid

    def _supervisor_pid_if_local(self) -> Callable[[], int | None] | None:
        """`_supervisor_pid` on one host; None when the bus spans hosts (no silence excused)."""
        return None if self.profile.allow_non_loopback else self._supervisor_pid

    def _delivery_pids(self) -> tuple[int, ...]:
        """Processes a supervisor state passes through to this watch: the router and this one."""
        return tuple(pid for pid in (self.router_pid, os.getpid()) if pid)

    def _run_job(self) -> int:
        job = self.options.job
        if job == "check":
            return EXIT_OK
        has_supervisor = any(s.name == "supervisor" for s in self.specs)
        if job == "none":
            say("stack running; press Ctrl-C to stop")
            if not has_supervisor:
                self.stop_requested.wait()
                return EXIT_INTERRUPTED if self.interrupted else (EXIT_FAILED if self.failure else EXIT_OK)
            # No job, but the supervisor is still watched: nothing else sees it freeze.
            watch = supervisor_watch_job(self._abort_reason, say, self._supervisor_pid_if_local(),
                                         self._delivery_pids())
            outcome = run_on_bus(self.bus_profile, self.stop_requested, watch, self.arm_stop)
            if self.interrupted:
                return EXIT_INTERRUPTED
            if not outcome.ok and not self.failure:
                self._fail(outcome.failure)
            return EXIT_FAILED if self.failure else EXIT_OK
        if job == "handover":
            if not has_supervisor:
                raise LauncherError("the handover job needs a supervisor service in the profile "
                                    "([services.supervisor]); use --job demo or check without one")
            on_bus = handover_job(self._episodes(), self.options.episode_timeout_s, self._abort_reason, say,
                                  self._supervisor_pid_if_local(), self._delivery_pids())
        else:
            on_bus = demo_job(self._abort_reason, say)
        self.episode_running = True  # no safety service is restarted from here on
        outcome = run_on_bus(self.bus_profile, self.stop_requested, on_bus, self.arm_stop)
        self.episode_running = False
        if self.interrupted:
            return EXIT_INTERRUPTED
        if not outcome.ok:
            if not self.failure:
                self._fail(outcome.failure)
            return EXIT_FAILED
        for line in outcome.summary:
            say(line)
        return EXIT_OK
