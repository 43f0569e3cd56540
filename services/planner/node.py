"""Bus wiring of the planner: HumanState + ObjectEstimate in (and the supervisor's phase, to
rest outside an episode: `core.planner_rests`), TransferTarget out.

All decisions are in `core.PlannerService`; this module only moves messages.
"""

from __future__ import annotations

import argparse
import logging

from bus_schema import topics as T
from handover_model import robots
from services.planner.config import load_config
from services.planner.core import PlannerService, planner_rests
from services.runtime import RateLimitedLog, ServiceNode, load_profile

log = logging.getLogger("planner")

#: Wait between two looks at the inputs (also bounds the republish jitter), s.
WAIT_S = 0.05
#: The latest plan is published again this often (s), so that a frozen planner is noticed by
#: the freshness of `planner/transfer` and a late subscriber gets the current plan.
REPUBLISH_PERIOD_S = 0.2
#: Wait between two looks while the supervisor is outside an episode (`core.planner_rests`):
#: nobody reads a plan then, and a new episode's `pick` leaves it a second and more, s.
REST_WAIT_S = 0.5


def run(args: argparse.Namespace) -> int:
    """Run the planner service until SIGINT/SIGTERM."""
    profile = load_profile(args)
    cfg = load_config(profile.service_config("planner"), robots.active())
    service = PlannerService(cfg)
    notes = RateLimitedLog(log, 2.0)
    with ServiceNode("planner", profile) as node:
        pub = node.publisher(T.TRANSFER)
        # Read at the loop's own pace (every `WAIT_S`): a 30 Hz human state need not wake it, the
        # plan goes out at most 50 ms after the newest estimate (issue 16: two thread wakes a
        # message fewer).
        human_sub = node.subscribe(T.HUMAN, queue_size=4, wake=False)
        object_sub = node.subscribe(T.OBJECT, queue_size=4, wake=False)
        supervisor_sub = node.subscribe(T.SUPERVISOR_STATE, queue_size=1, wake=False)
        log.info("planner ready: waiting for %s", T.HUMAN.key(profile.prefix))
        latest: dict | None = None
        last_put_s = 0.0
        loop = node.rate_loop(1.0 / WAIT_S)
        rest_ticks = 0
        for _tick in loop:
            human = human_sub.latest()
            obj = object_sub.latest()
            fields, note = service.step(
                human.msg if human else None,
                human.rx_monotonic if human else None,
                obj.msg.mass_kg if obj else 0.0,
                node.clock.now_s(),
            )
            now_s = node.clock.now_s()
            if fields is not None:
                latest = fields
            if latest is not None and (fields is not None or now_s - last_put_s >= REPUBLISH_PERIOD_S):
                pub.put(**latest)
                last_put_s = now_s
            if note is not None:
                if note.startswith("planned ("):
                    # Body-size estimates drift for the first seconds of tracking: those
                    # re-plans are DEBUG; the first plan, a moved receiver or object are INFO.
                    log.log(logging.DEBUG if " changed by " in note else logging.INFO, note)
                else:
                    notes.warning("plan", note)
            state = supervisor_sub.latest()
            if planner_rests(state.msg.phase if state else None, now_s - state.rx_monotonic if state else 0.0):
                rest_ticks += 1
                loop.rest_until(now_s + REST_WAIT_S)
        log.info("planner stopping after %d plans (%d ticks at rest)", service.plans_made, rest_ticks)
    return 0
