"""Heartbeats go out on each sender's own key (`runtime/heartbeat/<service>`), and a reader
drops a beat whose `source` names another service than its key (issue 17): with the bus's
access control a key is one login's, so a beat's sender is the login, never the payload."""

from __future__ import annotations

import time

from bus_schema import encode_for, topics
from services.runtime.testing import wait_until


def test_a_beat_counts_for_its_keys_sender_only(bus, make_node):
    profile, router = bus
    watcher = make_node("watcher")
    beats = watcher.subscribe(topics.HEARTBEAT, queue_size=1000)
    planner = make_node("planner")  # a node's own heartbeat thread beats on its own key
    assert wait_until(lambda: any(rx.msg.source == "planner" for rx in beats.drain()), 5.0)
    # A stranger's beat naming the planner, on the stranger's key and on the bare topic key.
    forged = topics.HEARTBEAT.type(seq=1, stamp_ns=time.time_ns(), source="planner", uptime_s=1.0, beats=1)
    payload = encode_for(topics.HEARTBEAT, forged)
    for key in (topics.HEARTBEAT.sender_key("gripper", profile.prefix), f"{profile.prefix}/runtime/heartbeat"):
        router.put(key, payload)
    planner.close()
    time.sleep(0.4)  # the forged beats have arrived (or been dropped) by now
    seen = beats.drain()
    assert all(rx.msg.source != "planner" or rx.msg.beats != 1 or rx.msg.uptime_s != 1.0 for rx in seen), seen
    assert beats.stats.rejected >= 1  # the beat on the gripper's key naming the planner
    assert topics.HEARTBEAT.key(profile.prefix) == f"{profile.prefix}/runtime/heartbeat/*"
    assert topics.topic_for_key(f"{profile.prefix}/runtime/heartbeat/gripper", profile.prefix) is topics.HEARTBEAT
    assert topics.topic_for_key(f"{profile.prefix}/runtime/heartbeat", profile.prefix) is None
    assert topics.topic_for_key(f"{profile.prefix}/robot/joint_state", profile.prefix) is topics.JOINT_STATE
