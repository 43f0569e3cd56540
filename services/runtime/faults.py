"""Fault injection on a service's publications, for the fault tests (never on by default).

Only a profile that says so takes rules: ``[testing] fault_injection = true`` (the fault
harness writes such a profile for its runs). In any other run the variable below is ignored,
with one warning: no environment variable can drop or delay a safety message of a
production stack (issue 17).

The environment variable `HANDOVER_FAULTS` holds rules separated by ``;``, each
``<service>:<topic suffix>:<kind>=<value>``:

- ``delay=<s>``: every message of that topic leaves `<s>` seconds late (order kept);
- ``drop=<p>``: each message of that topic is dropped with probability `<p>` (0–1).

Example: ``HANDOVER_FAULTS="gripper:gripper/release:delay=0.05;supervisor:motion/stop:drop=0.5"``.
A rule for another service is ignored. Drops use a generator seeded from
`HANDOVER_FAULTS_SEED` (default 0), so a fault run is repeatable.

With `HANDOVER_FAULTS_ARM_DIR=<dir>` a rule only acts while the file
``<dir>/<service>.<topic suffix with / as .>`` exists (`arm_file_name`), so a test can
open and close a fault window at a chosen handover phase; without it the rules act from
the start.
"""

from __future__ import annotations

import os
import queue
import random
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from services.runtime.errors import ProfileError

ENV_VAR = "HANDOVER_FAULTS"
SEED_ENV_VAR = "HANDOVER_FAULTS_SEED"
ARM_DIR_ENV_VAR = "HANDOVER_FAULTS_ARM_DIR"
MAX_DELAY_S = 10.0
#: An armed rule looks for its arm file at most this often, s.
ARM_CHECK_PERIOD_S = 0.005


def arm_file_name(service: str, suffix: str) -> str:
    """Name of the file that arms `service`'s rule on `suffix` (in `HANDOVER_FAULTS_ARM_DIR`)."""
    return f"{service}.{suffix.replace('/', '.')}"


@dataclass(frozen=True)
class FaultRule:
    """One injected fault: `service`'s messages on `suffix` are delayed or dropped."""

    service: str
    suffix: str
    kind: str  # "delay" or "drop"
    value: float


def parse_rules(text: str) -> list[FaultRule]:
    """Rules from the `HANDOVER_FAULTS` syntax (see the module docstring).

    Raises:
        ProfileError: a rule that does not parse, naming it.
    """
    rules = []
    for part in (p.strip() for p in text.split(";")):
        if not part:
            continue
        try:
            service, suffix, action = part.split(":")
            kind, value_text = action.split("=")
            value = float(value_text)
        except ValueError:
            raise ProfileError(f"{ENV_VAR}: cannot parse {part!r}; "
                               "use <service>:<topic>:delay=<s> or drop=<p>") from None
        if kind == "delay" and not 0.0 <= value <= MAX_DELAY_S:
            raise ProfileError(f"{ENV_VAR}: delay must be within 0–{MAX_DELAY_S:g} s in {part!r}")
        if kind == "drop" and not 0.0 <= value <= 1.0:
            raise ProfileError(f"{ENV_VAR}: drop probability must be within 0–1 in {part!r}")
        if kind not in ("delay", "drop"):
            raise ProfileError(f"{ENV_VAR}: unknown fault {kind!r} in {part!r} (delay or drop)")
        rules.append(FaultRule(service.strip(), suffix.strip(), kind, value))
    return rules


def rules_for(service: str, environ: dict[str, str] | None = None, enabled: bool = True) -> dict[str, FaultRule]:
    """This service's rules by topic suffix (empty when the variable is unset, or when
    `enabled` is False: the profile does not allow fault injection)."""
    env = os.environ if environ is None else environ
    text = env.get(ENV_VAR, "")
    if text and not enabled:
        import logging

        logging.getLogger(__name__).warning(
            "%s is set but ignored: this profile does not allow fault injection ([testing] fault_injection = true "
            "is for fault tests only)", ENV_VAR)
        return {}
    return {r.suffix: r for r in parse_rules(text) if r.service == service} if text else {}


class FaultyPut:
    """Wraps a put function with one fault rule (delay on a worker thread, or drop)."""

    def __init__(self, put: Callable[[bytes], None], rule: FaultRule, seed: int | None = None) -> None:
        self._put = put
        self.rule = rule
        self._rng = random.Random(int(os.environ.get(SEED_ENV_VAR, "0")) if seed is None else seed)
        self.dropped = 0
        self.delayed = 0
        arm_dir = os.environ.get(ARM_DIR_ENV_VAR, "")
        self._arm_path = os.path.join(arm_dir, arm_file_name(rule.service, rule.suffix)) if arm_dir else None
        self._armed = self._arm_path is None
        self._armed_checked_s = -1.0
        self._queue: queue.Queue[tuple[float, bytes] | None] | None = None
        if rule.kind == "delay":
            self._queue = queue.Queue()
            threading.Thread(target=self._deliver, name=f"fault delay {rule.suffix}", daemon=True).start()

    def active(self) -> bool:
        """The rule acts now (always, unless an arm directory is set and its file is absent)."""
        if self._arm_path is None:
            return True
        now = time.monotonic()
        if now - self._armed_checked_s >= ARM_CHECK_PERIOD_S:
            self._armed_checked_s = now
            self._armed = os.path.exists(self._arm_path)
        return self._armed

    def __call__(self, payload: bytes) -> None:
        if not self.active():
            if self._queue is not None and not self._queue.empty():
                self._queue.put((time.monotonic(), payload))  # behind the delayed ones: order kept
            else:
                self._put(payload)
            return
        if self.rule.kind == "drop":
            if self._rng.random() < self.rule.value:
                self.dropped += 1
                return
            self._put(payload)
            return
        assert self._queue is not None
        self.delayed += 1
        self._queue.put((time.monotonic() + self.rule.value, payload))

    def _deliver(self) -> None:
        assert self._queue is not None
        while True:
            item = self._queue.get()
            if item is None:
                return
            due_s, payload = item
            wait = due_s - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            try:
                self._put(payload)
            except Exception:  # noqa: BLE001 - shutdown: the session closed while a delayed message waited
                return

    def close(self) -> None:
        if self._queue is not None:
            self._queue.put(None)
