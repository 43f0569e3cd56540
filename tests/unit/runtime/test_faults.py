"""HANDOVER_FAULTS parsing and the delay/drop wrappers."""

from __future__ import annotations

import time

import pytest

from services.runtime.errors import ProfileError
from services.runtime.faults import FaultRule, FaultyPut, parse_rules, rules_for


def test_rules_parse_and_filter_by_service():
    env = {"HANDOVER_FAULTS": "gripper:gripper/release:delay=0.05; supervisor:motion/stop:drop=0.5"}
    assert rules_for("gripper", env) == {"gripper/release": FaultRule("gripper", "gripper/release", "delay", 0.05)}
    assert rules_for("supervisor", env)["motion/stop"].value == 0.5
    assert rules_for("bridge", env) == {} and rules_for("bridge", {}) == {}


@pytest.mark.parametrize("text", ["gripper:delay=1", "a:b:delay=x", "a:b:drop=2", "a:b:delay=-1", "a:b:shake=1"])
def test_bad_rules_are_refused_in_one_line(text):
    with pytest.raises(ProfileError, match="HANDOVER_FAULTS"):
        parse_rules(text)


def test_drop_drops_about_the_asked_fraction_repeatably():
    sent: list[bytes] = []
    put = FaultyPut(sent.append, FaultRule("s", "t", "drop", 0.3), seed=7)
    for i in range(2000):
        put(bytes([i % 256]))
    assert 0.25 < put.dropped / 2000 < 0.35 and len(sent) + put.dropped == 2000
    again: list[bytes] = []
    put2 = FaultyPut(again.append, FaultRule("s", "t", "drop", 0.3), seed=7)
    for i in range(2000):
        put2(bytes([i % 256]))
    assert again == sent


def test_delay_keeps_order_and_holds_each_message_back():
    arrivals: list[tuple[float, bytes]] = []
    put = FaultyPut(lambda p: arrivals.append((time.monotonic(), p)), FaultRule("s", "t", "delay", 0.1))
    t0 = time.monotonic()
    for i in range(3):
        put(bytes([i]))
    deadline = time.monotonic() + 2.0
    while len(arrivals) < 3 and time.monotonic() < deadline:
        time.sleep(0.01)
    put.close()
    assert [p for _, p in arrivals] == [b"\x00", b"\x01", b"\x02"]
    assert all(t - t0 >= 0.1 for t, _ in arrivals)


def test_rules_are_ignored_with_a_warning_unless_the_profile_allows_fault_injection(caplog):
    env = {"HANDOVER_FAULTS": "gripper:gripper/release:delay=0.05"}
    assert rules_for("gripper", env, enabled=False) == {}
    assert "ignored: this profile does not allow fault injection" in caplog.text
    assert set(rules_for("gripper", env, enabled=True)) == {"gripper/release"}


def test_only_a_testing_table_turns_fault_injection_on(tmp_path):
    from services.runtime.profile import load_profile_file

    assert load_profile_file("sim").fault_injection is False  # no shipped profile allows it
    path = tmp_path / "faults.toml"
    path.write_text(load_profile_file("sim").path.read_text() + "\n[testing]\nfault_injection = true\n")
    assert load_profile_file(path).fault_injection is True
    path.write_text('[testing]\nfault_injection = "yes"\n')
    with pytest.raises(ProfileError, match=r"\[testing\] may hold only fault_injection"):
        load_profile_file(path)
