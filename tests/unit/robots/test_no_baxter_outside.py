"""Nothing outside the robot descriptions names the Baxter arm (issue 18): every service reads
its arm from `handover_model.robots`.

Exceptions, whole folders: the descriptions (`handover_model/robots/`), the Baxter hardware
backend (`services/bridge/baxter/`) and the ROS 1 Kinect path (`services/tracker/ros1/`, which
reuses that backend's ROS 1 machinery). Elsewhere a module may name the hardware backend, not
the arm: its module, its fake (`fake_baxter`), its config table and its `backend = "baxter"`
value, its commands and its docs page (`BACKEND_NAMES`)."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
PACKAGES = ("bus_schema", "handover_model", "robot_sim", "services")
EXEMPT_FOLDERS = ("handover_model/robots/", "services/bridge/baxter/", "services/tracker/ros1/")
#: How a module names the Baxter hardware backend (not the arm).
BACKEND_NAMES = re.compile(
    r"services\.bridge\.baxter[\w.]*|fake[_ ]baxter|handover-(?:bridge|fake)-baxter|Baxter(?:Config|Backend)\b"
    r"|docs/baxter\.md|config\.baxter\b|baxter=|[\"'`]baxter[\"'`]|\bbaxter:|known: sim, baxter"
    r"|Baxter (?:backend|hardware backend|profiles)", re.IGNORECASE)


def offending_lines(text: str) -> list[str]:
    """Lines that still name Baxter once the backend's names are taken out."""
    return [line.strip() for line in text.splitlines() if "baxter" in BACKEND_NAMES.sub("", line).lower()]


def test_the_rule_sees_the_arm_and_lets_the_backend_be_named():
    assert offending_lines("q = Baxter's right arm\nbackend = \"baxter\"  # services.bridge.baxter") == [
        "q = Baxter's right arm"]
    assert offending_lines("from services.bridge.baxter.backend import BaxterBackend") == []


def test_no_module_outside_the_descriptions_names_baxter():
    found = []
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            rel = path.relative_to(REPO).as_posix()
            if rel.startswith(EXEMPT_FOLDERS):
                continue
            found += [f"{rel}: {line}" for line in offending_lines(path.read_text())]
    assert found == [], "\n".join(found)
