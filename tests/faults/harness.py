"""Run `handover-up` as a real subprocess and inject faults at chosen handover phases.

`run_with_faults(plans, receiver=...)`:

1. starts ``python -m services.launcher --port <free port> --receiver <r> --episodes 1
   --verbose`` (every service's lines in its output: the supervisor's ``service fault`` and
   starvation lines are read there) in its own process group (`HANDOVER_FAULTS` rules for
   the delay/drop plans, armed through `HANDOVER_FAULTS_ARM_DIR` so they act only from their
   phase on), reads its output and the children's PIDs from the ``[launcher] started <name>
   (pid N)`` lines;
2. observes the bus from the test process (a `ServiceNode` on the same port): supervisor
   state and episode summaries, sim truth, joint states, motion stops and goals, release
   events;
3. waits for each plan's phase (in order) and injects: SIGKILL, SIGSTOP (SIGCONT after the
   plan's duration, and always before cleanup), arming a delay/drop rule, or a flood of
   random bytes and structured mutations at a bounded rate for a bounded time;
4. waits for `handover-up` to exit and returns a `RunRecord` (see `invariants.judge`).

Only processes this harness started are signalled, by PID (the launcher, and its children
whose PIDs it printed, checked against their command line), in a `finally`.
"""

from __future__ import annotations

import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import replace
from collections.abc import Iterator
from pathlib import Path

import psutil

from bus_schema import DecodeError, decode, topics
from services.launcher.logins import OBSERVER, login_profile
from services.runtime import ServiceNode
from services.runtime.node import open_session
from services.runtime.faults import ARM_DIR_ENV_VAR, ENV_VAR, arm_file_name
from services.runtime.bus_access import BusAuth
from services.runtime.profile import free_tcp_port, load_profile_file
from tests.faults.invariants import FaultPlan, Injection, RunRecord
from tests.faults.mutations import random_payloads, structured_payloads
from tests.samples import SAMPLES

REPO = Path(__file__).resolve().parents[2]
_STARTED = re.compile(r"^\[launcher\] started (?P<name>\w+) \(pid (?P<pid>\d+)\)")
_EXIT = re.compile(r"^\[launcher\] exit (?P<code>\d+)")
#: Phases in handover order (a plan for a phase already passed is reported as missed).
PHASE_ORDER = ("locate", "pick", "plan", "reach", "transfer", "released", "retract", "done")


class HarnessError(RuntimeError):
    """The harness could not run the stack (the message says what to check)."""


class _Launcher:
    """The `handover-up` subprocess and its output lines (with test-monotonic rx times)."""

    def __init__(self, args: list[str], env: dict[str, str]) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "services.launcher", *args], stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True, env=env, cwd=REPO,
            start_new_session=True,
        )
        self.lines: list[tuple[float, str]] = []
        self.pids: dict[str, int] = {}
        self._reader = threading.Thread(target=self._read, name="handover-up output", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for raw in self.proc.stdout:
            line = raw.rstrip("\n")
            self.lines.append((time.monotonic(), line))
            m = _STARTED.match(line)
            if m:
                self.pids[m["name"]] = int(m["pid"])

    def join_reader(self, timeout_s: float = 5.0) -> None:
        self._reader.join(timeout_s)


def _owned(pid: int, service: str) -> psutil.Process | None:
    """The process `pid` if it is still the `service` child we started (PID reuse guard)."""
    try:
        p = psutil.Process(pid)
        cmd = " ".join(p.cmdline())
        # The service's module: services.<name>, except the simulated Kinect (services.sim_kinect).
        return p if f"services.{service}" in cmd or f"services.sim_{service}" in cmd else None
    except (psutil.NoSuchProcess, psutil.AccessDenied):
        return None


def _signal(pid: int, service: str, sig: int) -> bool:
    p = _owned(pid, service)
    if p is None:
        return False
    try:
        p.send_signal(sig)
        return True
    except psutil.NoSuchProcess:
        return False


def garbage(topic: topics.Topic, rng: random.Random) -> Iterator[bytes]:
    """Payloads that do NOT decode as `topic`'s type: random bytes and structured mutations
    of a valid sample, alternately. A mutation that still decodes is a valid message (e.g. a
    real release event), not garbage: it is skipped."""
    random_gen = random_payloads(rng, 10**12)
    mutated = structured_payloads(rng, SAMPLES[topic.suffix], 10**12)
    i = 0
    while True:
        payload = next(random_gen) if i % 2 else next(mutated)
        try:
            decode(topic, payload)
        except DecodeError:
            i += 1
            yield payload


def _flood(node: ServiceNode, plan: FaultPlan, stop: threading.Event, inj: Injection) -> None:
    """Publish `garbage` on `plan.topic` at `plan.rate_hz` for `plan.duration_s` (bounded in
    rate and time)."""
    topic = topics.TOPICS_BY_SUFFIX[plan.topic or ""]
    # As the service itself (its own login: the worst case the bus's access control leaves).
    auth = node.profile.auth
    as_service = node.profile if auth is None else replace(node.profile, auth=BusAuth(
        auth.credentials_file.parent / plan.service))
    session = open_session(as_service, "client", timeout_s=10.0, user=plan.service)
    pub = session.declare_publisher(topic.sender_key(plan.service, node.profile.prefix))
    rng = random.Random(hash(plan.label) & 0xFFFF)
    batch = 10
    period_s = batch / plan.rate_hz
    end_s = inj.at_s + plan.duration_s
    payloads = garbage(topic, rng)
    next_s = time.monotonic()
    while not stop.is_set() and time.monotonic() < end_s:
        for i in range(batch):
            pub.put(next(payloads))
        inj.sent += batch
        next_s += period_s
        time.sleep(max(0.0, next_s - time.monotonic()))
    inj.ended_s = time.monotonic()
    session.close()


def run_with_faults(plans: list[FaultPlan], receiver: str = "absent", seed: int = 0,
                    run_timeout_s: float = 120.0, extra_args: tuple[str, ...] = (),
                    log_path: Path | None = None) -> RunRecord:
    """One `handover-up` run with `plans` injected in order (see the module docstring)."""
    port = free_tcp_port()
    workdir = Path(tempfile.mkdtemp(prefix="faults-"))
    # The services take HANDOVER_FAULTS rules only from a profile that allows fault injection.
    profile_path = workdir / "faults.toml"
    profile_path.write_text(load_profile_file("sim").path.read_text() + "\n[testing]\nfault_injection = true\n")
    profile = load_profile_file(profile_path).with_bus(endpoint=f"tcp/127.0.0.1:{port}")
    arm_dir = workdir / "armed"
    arm_dir.mkdir()
    env = dict(os.environ)
    env["PYTHONUNBUFFERED"] = "1"
    rules = [f"{p.service}:{p.topic}:{p.kind}={p.value:g}" for p in plans if p.kind in ("delay", "drop")]
    env.pop(ENV_VAR, None)
    if rules:
        env[ENV_VAR] = ";".join(rules)
        env[ARM_DIR_ENV_VAR] = str(arm_dir)
    args = ["--profile", str(profile_path), "--port", str(port), "--receiver", receiver, "--episodes", "1",
            "--seed", str(seed), "--recording-dir", str(workdir), "--run-id", "fault", "--verbose", *extra_args]
    rec = RunRecord(receiver=receiver)
    launcher = _Launcher(args, env)
    node: ServiceNode | None = None
    frozen: list[tuple[int, str]] = []
    flood_stop = threading.Event()
    floods: list[threading.Thread] = []
    armed: list[tuple[Path, float | None]] = []
    deadline = time.monotonic() + run_timeout_s
    try:
        observer = login_profile(profile, workdir, "fault", OBSERVER, timeout_s=30.0)  # the run's own logins
        node = ServiceNode(OBSERVER, observer, install_signal_handlers=False, connect_timeout_s=30.0)
        node.open()
        subs = {
            "states": node.subscribe(topics.SUPERVISOR_STATE, 100_000),
            "summaries": node.subscribe(topics.EPISODE, 1000),
            "truth": node.subscribe(topics.SIM_TRUTH, 100_000),
            "joints": node.subscribe(topics.JOINT_STATE, 100_000),
            "stops": node.subscribe(topics.MOTION_STOP, 100_000),
            "goals": node.subscribe(topics.MOTION_GOAL, 1000),
            "releases": node.subscribe(topics.GRIPPER_RELEASE, 1000),
            "targets": node.subscribe(topics.TRANSFER, 10_000),
        }

        def pump() -> None:
            for name, sub in subs.items():
                getattr(rec, name).extend((r.rx_monotonic, r.msg) for r in sub.drain())

        pending = list(plans)
        phase_seen: dict[str, float] = {}
        thaw_at: list[tuple[float, int, str]] = []
        while launcher.proc.poll() is None and time.monotonic() < deadline:
            node.wait(0.002)
            n_before = len(rec.states)
            pump()
            for t, msg in rec.states[n_before:]:
                phase_seen.setdefault(msg.phase, t)
            now = time.monotonic()
            for when, pid, service in list(thaw_at):
                if now >= when:
                    _signal(pid, service, signal.SIGCONT)
                    thaw_at.remove((when, pid, service))
                    frozen[:] = [f for f in frozen if f[0] != pid]
                    for inj in rec.injections:
                        if inj.pid == pid and inj.ended_s is None:
                            inj.ended_s = now
            for path, until in list(armed):
                if until is not None and now >= until:
                    path.unlink(missing_ok=True)
                    armed.remove((path, until))
            while pending:
                plan = pending[0]
                seen = phase_seen.get(plan.phase)
                if seen is None:
                    terminal = {"protective_stop", "done", "failed"} & set(phase_seen)
                    if terminal:
                        rec.phases_missed.append(plan.label)
                        pending.pop(0)
                        continue
                    break
                if now < seen + plan.offset_s:
                    break
                pending.pop(0)
                rec.injections.append(_inject(plan, launcher, node, seen, arm_dir, frozen, thaw_at, armed,
                                              floods, flood_stop))
        if launcher.proc.poll() is None:
            raise HarnessError(f"handover-up did not finish within {run_timeout_s:.0f} s")
        launcher.join_reader()
        time.sleep(0.05)
        pump()
    finally:
        flood_stop.set()
        for t in floods:
            t.join(5.0)
        for pid, service in frozen:
            _signal(pid, service, signal.SIGCONT)
        if launcher.proc.poll() is None:
            launcher.proc.send_signal(signal.SIGINT)
            try:
                launcher.proc.wait(30.0)
            except subprocess.TimeoutExpired:
                launcher.proc.kill()
                launcher.proc.wait(5.0)
        for service, pid in launcher.pids.items():
            _signal(pid, service, signal.SIGKILL)  # only if it outlived its launcher
        if node is not None:
            node.close()
        launcher.join_reader()
        rec.lines = list(launcher.lines)
        rec.exit_code = launcher.proc.returncode
        exits = [line for _t, line in rec.lines if _EXIT.match(line)]
        rec.exit_line = exits[-1] if exits else ""
        if log_path is not None:
            log_path.parent.mkdir(parents=True, exist_ok=True)
            log_path.write_text("\n".join(line for _t, line in rec.lines) + "\n")
        for path in arm_dir.glob("*"):
            path.unlink(missing_ok=True)
        for path in workdir.glob("*.rrd"):
            path.unlink(missing_ok=True)
        shutil.rmtree(workdir / "handover-fault-logs", ignore_errors=True)  # the same lines as `rec.lines`
    return rec


def _inject(plan: FaultPlan, launcher: _Launcher, node: ServiceNode, phase_seen_s: float, arm_dir: Path,
            frozen: list[tuple[int, str]], thaw_at: list[tuple[float, int, str]],
            armed: list[tuple[Path, float | None]], floods: list[threading.Thread],
            flood_stop: threading.Event) -> Injection:
    pid = launcher.pids.get(plan.service) if plan.kind in ("kill", "freeze") else None
    if plan.kind in ("kill", "freeze") and pid is None:
        raise HarnessError(f"no PID for {plan.service} in the launcher's output")
    inj = Injection(plan, time.monotonic(), time.time(), phase_seen_s, pid)
    if plan.kind == "kill":
        assert pid is not None
        if not _signal(pid, plan.service, signal.SIGKILL):
            raise HarnessError(f"{plan.service} (pid {pid}) is not running: cannot kill it")
    elif plan.kind == "freeze":
        assert pid is not None
        if not _signal(pid, plan.service, signal.SIGSTOP):
            raise HarnessError(f"{plan.service} (pid {pid}) is not running: cannot freeze it")
        frozen.append((pid, plan.service))
        thaw_at.append((inj.at_s + plan.duration_s, pid, plan.service))
    elif plan.kind in ("delay", "drop"):
        path = arm_dir / arm_file_name(plan.service, plan.topic or "")
        path.touch()
        armed.append((path, inj.at_s + plan.duration_s if plan.duration_s > 0 else None))
    elif plan.kind == "flood":
        t = threading.Thread(target=_flood, args=(node, plan, flood_stop, inj), name=f"flood {plan.topic}",
                             daemon=True)
        t.start()
        floods.append(t)
    else:
        raise HarnessError(f"unknown fault kind {plan.kind!r}")
    return inj
