"""CPU of one sim-bridge tick per state of the scripted handover, this code against a baseline
revision, in one process (the bridge tick benchmark of docs/bridge.md).

`baseline_package` copies a revision's versions of the files a sim tick runs (the contact
plant package, the handover scene, the bridge's sim backends) out of git (`git show`) into a
package under a temporary folder, their imports among themselves rewritten, so that the old
and the new backend run side by side. Each tick is timed with the thread's CPU clock
(`time.thread_time_ns`) around what the bridge loop does with the backend: read, grip
command, command or hold, step, read, and the four messages built and msgpack-encoded as the
publishers do (no bus). States, from `handover_script`: ``rest`` (a, the receiver holds the
object, the arm holds still), ``held_still`` (b, the object in the gripper before the
transfer), ``transfer`` (c), ``moving_empty`` (d), and ``rest_dropped`` (the object fell).
The two versions take turns round by round, and every tick's published bytes are compared.

Run: python -m tests.bench.bridge_tick_cpu [--rev 9acd660] [--rounds 5] [--period-s 0.01]
"""

from __future__ import annotations

import argparse
import functools
import importlib
import importlib.util
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from bus_schema import topics
from bus_schema.codec import encode_for
from tests.unit.bridge import handover_script as hs

REPO = Path(__file__).resolve().parents[2]
#: The last commit before the cheaper tick.
BASELINE_REV = "9acd660"
_MODULES = ("services/bridge/backend.py", "services/bridge/handover_backend.py", "robot_sim/handover_scene.py")
STATES = ("rest", "held_still", "transfer", "moving_empty", "rest_dropped")


@functools.lru_cache(maxsize=None)
def _show(rev: str, path: str) -> str | None:
    """`path`'s text at `rev`, or None when it is not there."""
    done = subprocess.run(["git", "show", f"{rev}:{path}"], cwd=REPO, capture_output=True, text=True)
    return done.stdout if done.returncode == 0 else None


def _moved_module_path(rev: str, module: str) -> str | None:
    """`rev`'s file of project module `module` when it no longer imports here, else None."""
    try:
        if importlib.util.find_spec(module) is not None:
            return None
    except ModuleNotFoundError:
        pass
    base = module.replace(".", "/")
    return next((c for c in (f"{base}.py", f"{base}/__init__.py") if _show(rev, c) is not None), None)


def _with_moved_imports(rev: str, paths: list[str]) -> list[str]:
    """`paths` plus, transitively, `rev`'s files of the project modules they import that no
    longer exist (a module moved since, e.g. ``robot_sim.baxter`` into ``handover_model``)."""
    paths, k = list(paths), 0
    while k < len(paths):
        text = _show(rev, paths[k]) or ""
        k += 1
        for package, names in re.findall(r"^\s*from ((?:robot_sim|services|handover_model)(?:\.\w+)*) import ([\w, ]+)",
                                         text, re.M):
            for module in [package] + [f"{package}.{n.strip()}" for n in names.split(",") if n.strip()]:
                path = _moved_module_path(rev, module)
                if path is not None and path not in paths:
                    paths.append(path)
    return paths


def baseline_package(rev: str, into: Path, name: str = "bridge_baseline") -> str:
    """Write `rev`'s tick files as package `name` under `into` (added to sys.path); returns
    the module name of its `services.bridge.backend`."""
    listing = subprocess.run(["git", "ls-tree", "--name-only", rev, "robot_sim/contact/"], cwd=REPO,
                             check=True, capture_output=True, text=True).stdout.split()
    paths = _with_moved_imports(rev, [p for p in listing if p.endswith(".py")] + list(_MODULES))
    dotted = {p[:-3].replace("/", "."): p[:-3].replace("/", "__") for p in paths}
    package = into / name
    package.mkdir(parents=True, exist_ok=True)
    (package / "__init__.py").write_text("")
    for path in paths:
        text = _show(rev, path)
        if text is None:
            raise FileNotFoundError(f"{path} is not in revision {rev}")
        for module, flat in sorted(dotted.items(), key=lambda kv: -len(kv[0])):
            parent, _, leaf = module.rpartition(".")  # ``from robot_sim import scene``
            text = re.sub(rf"^(\s*)from {re.escape(parent)} import {leaf}$", rf"\1from {name} import {flat} as {leaf}",
                          text, flags=re.M)
            text = text.replace(f"from {module} import", f"from {name}.{flat} import")
        (package / (path[:-3].replace("/", "__") + ".py")).write_text(text)
    if str(into) not in sys.path:
        sys.path.insert(0, str(into))
    return f"{name}.services__bridge__backend"


class _Publisher:
    """Builds and encodes a message as `TypedPublisher.put` does; keeps the bytes if asked."""

    def __init__(self, topic, sink: list | None) -> None:
        self.topic, self.sink, self.seq = topic, sink, 0

    def put(self, **fields) -> None:
        data = encode_for(self.topic, self.topic.type(seq=self.seq, stamp_ns=0, source="bridge", **fields))
        self.seq += 1
        if self.sink is not None:
            self.sink.append(data)


class Loop:
    """The bridge loop's work with its backend on one tick (`services.bridge.arm_loop.ArmLoop.tick`)."""

    def __init__(self, backend, sink: list | None = None) -> None:
        self.backend, self.sink = backend, sink
        self.state_pub = _Publisher(topics.JOINT_STATE, sink)
        self.pubs: dict[str, _Publisher] = {}

    def _publish_extra(self, suffix: str, fields: dict) -> None:
        pub = self.pubs.get(suffix)
        if pub is None:
            pub = self.pubs[suffix] = _Publisher(topics.TOPICS_BY_SUFFIX[suffix], self.sink)
        pub.put(**fields)

    def tick(self, tick: hs.Tick) -> None:
        b = self.backend
        hs.apply(b, tick)
        r = b.read()
        self.state_pub.put(names=list(b.joint_names), position_rad=r.position_rad.tolist(),
                           velocity_rad_s=r.velocity_rad_s.tolist(), effort_nm=r.effort_nm.tolist(),
                           holding=tick.target_rad is None, backend=b.name, enabled=bool(getattr(b, "enabled", True)))
        b.publish_extras(self._publish_extra)


def _workload(make) -> list[tuple[str, list[hs.Tick]]]:
    """(behaviour, ticks) of the benchmark: a taking and a dropping episode, empty moves."""
    poses, out = hs.poses(), []
    for behaviour in ("taking", "dropping"):
        backend, ticks = make(behaviour), []
        for tick in hs.script(backend, poses, rest_s=10.0):
            hs.apply(backend, tick)
            ticks.append(tick)
        out.append((behaviour, ticks))
    out.append(("taking", list(hs.empty_moves(poses, cycles=3))))
    return out


def compare(rev: str = BASELINE_REV, rounds: int = 5, into: Path = Path("/tmp/bridge_tick_baseline"),
            period_s: float = 0.0) -> dict:
    """Per state and version, the tick CPU samples (µs); fails if any tick published other
    bytes in the two versions. `period_s` > 0: one tick per period (s), asleep in between,
    as the bridge loop runs (its caches cool down between ticks); 0: back to back."""
    makers = {"baseline": importlib.import_module(baseline_package(rev, into)).make_backend,
              "new": importlib.import_module("services.bridge.backend").make_backend}

    def make(version: str):
        def build(behaviour: str):
            cfg = hs.profile_config(behaviour)
            return makers[version](cfg.backend, contact=cfg.contact, time_constant_s=cfg.servo_time_constant_s,
                                   robot_command_timeout_s=cfg.sim_robot_command_timeout_s)
        return build

    workload = _workload(make("baseline"))
    samples: dict[str, dict[str, list[float]]] = {v: {s: [] for s in STATES} for v in makers}
    for r in range(rounds):
        for behaviour, ticks in workload:
            sinks: dict[str, list[bytes]] = {v: [] for v in makers}
            order = list(makers) if r % 2 == 0 else list(makers)[::-1]
            loops = {v: Loop(make(v)(behaviour), sinks[v] if r == 0 else None) for v in order}
            for version in order:
                clock, loop = time.thread_time_ns, loops[version]
                for tick in ticks:
                    if period_s > 0.0:
                        time.sleep(period_s - (time.monotonic() % period_s))
                    t0 = clock()
                    loop.tick(tick)
                    state = "rest_dropped" if tick.state == "rest" and behaviour == "dropping" else tick.state
                    if state in STATES:
                        samples[version][state].append((clock() - t0) / 1000.0)
            if sinks["baseline"] != sinks["new"]:
                raise AssertionError(f"{behaviour}: the two versions published different bytes")
    return samples


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rev", default=BASELINE_REV)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--period-s", type=float, default=0.0, help="0.01: paced like the 100 Hz loop")
    args = parser.parse_args()
    samples = compare(args.rev, args.rounds, period_s=args.period_s)
    print("| state | baseline median µs | p99 | new median µs | p99 | baseline/new (median) |")
    print("|---|---|---|---|---|---|")
    for state in STATES:
        b, n = np.array(samples["baseline"][state]), np.array(samples["new"][state])
        print(f"| {state} | {np.median(b):.1f} | {np.percentile(b, 99):.1f} | {np.median(n):.1f} | "
              f"{np.percentile(n, 99):.1f} | ×{np.median(b) / np.median(n):.2f} |")


if __name__ == "__main__":
    main()
