"""The multi-host profile on loopback, with separate processes: user/password authentication
(wrong credentials cannot connect) and the deny-by-default ACL (a service publishing where it
is not allowed is dropped — silently, so the test checks that the subscriber never receives
it while an allowed publisher's message on the same key does arrive). Also: the default
profile listens on loopback only."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import psutil
import pytest

from services.runtime.node import open_session
from services.launcher.certs import make_certificates
from services.runtime.profile import free_tcp_port, load_profile_file
from services.runtime.zenoh_config import zenoh_config_dict
from services.runtime.testing import BusRouter, wait_until

USERS = {"bridge": "b-pw", "ros1": "r-pw", "motion": "m-pw", "gripper": "g-pw", "supervisor": "s-pw",
         "planner": "p-pw", "tracker": "t-pw", "recorder": "rec-pw", "kinect": "k-pw", "launcher": "l-pw"}


def _credentials(path, users):
    path.write_text("".join(f"{u}:{p}\n" for u, p in users.items()))
    path.chmod(0o600)
    return path


@pytest.fixture
def multihost(tmp_path, monkeypatch):
    """The shipped multihost profile moved to loopback, over mutual TLS with certificates made
    now (`handover-certs`' code), with a router (in this process)."""
    creds = _credentials(tmp_path / "bus_credentials", USERS)
    monkeypatch.setenv("HANDOVER_BUS_CREDENTIALS", str(creds))
    make_certificates(tmp_path / "tls", ["127.0.0.1"])
    text = load_profile_file("multihost").path.read_text()
    text = text.replace("~/.config/handover/tls/192.168.1.10", str(tmp_path / "tls" / "127.0.0.1"))
    text = text.replace("~/.config/handover/tls/ca.pem", str(tmp_path / "tls" / "ca.pem"))
    path = tmp_path / "multihost.toml"
    path.write_text(text.replace("tls/192.168.1.10:7447", f"tls/127.0.0.1:{free_tcp_port()}"))
    profile = load_profile_file(path)
    assert profile.endpoint.startswith("tls/") and profile.tls is not None
    with BusRouter(profile) as router:
        yield profile, router, tmp_path


def _probe(profile, user, puts=(), creds=None, repeat=20):
    env = dict(os.environ)
    if creds is not None:
        env["HANDOVER_BUS_CREDENTIALS"] = str(creds)
    cmd = [sys.executable, "-m", "tests.integration.acl_probe", "--profile", str(profile.path),
           "--endpoint", profile.endpoint, "--user", user, "--repeat", str(repeat)]
    for key, payload in puts:
        cmd += ["--put", key, payload]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=60, env=env)


def test_wrong_credentials_cannot_connect(multihost):
    profile, _, tmp_path = multihost
    ok = _probe(profile, "motion")
    assert ok.returncode == 0 and "connected" in ok.stdout, ok.stdout + ok.stderr
    wrong = _credentials(tmp_path / "wrong", {**USERS, "motion": "guessed"})
    refused = _probe(profile, "motion", creds=wrong)
    assert refused.returncode == 3 and "refused" in refused.stdout, refused.stdout + refused.stderr
    unknown = _credentials(tmp_path / "unknown", {"intruder": "x"})
    assert _probe(profile, "intruder", creds=unknown).returncode == 3


def test_only_the_allowed_service_publishes_safety_keys(multihost):
    profile, _, _ = multihost
    prefix = profile.prefix
    received: list[tuple[str, bytes]] = []
    watcher = open_session(profile, "client", timeout_s=5.0, user="recorder")
    try:
        sub = watcher.declare_subscriber(f"{prefix}/**", lambda s: received.append((str(s.key_expr),
                                                                                     s.payload.to_bytes())))
        stop, grip, joint = f"{prefix}/motion/stop", f"{prefix}/gripper/command", f"{prefix}/robot/joint_command"
        # Intruders first: each tries a key it does not own.
        assert _probe(profile, "gripper", [(stop, "stop-from-gripper")]).returncode == 0
        assert _probe(profile, "motion", [(grip, "grip-from-motion")]).returncode == 0
        assert _probe(profile, "supervisor", [(joint, "joint-from-supervisor")]).returncode == 0
        assert _probe(profile, "bridge", [(joint, "joint-from-bridge")]).returncode == 0
        # Then the owners.
        assert _probe(profile, "supervisor", [(stop, "stop-from-supervisor")]).returncode == 0
        assert _probe(profile, "gripper", [(grip, "grip-from-gripper")]).returncode == 0
        assert _probe(profile, "motion", [(joint, "joint-from-motion")]).returncode == 0
        assert wait_until(lambda: {p for _, p in received} >= {b"stop-from-supervisor", b"grip-from-gripper",
                                                                b"joint-from-motion"}, 5.0), received
        time.sleep(0.2)
        payloads = {p for _, p in received}
        assert not payloads & {b"stop-from-gripper", b"grip-from-motion", b"joint-from-supervisor",
                               b"joint-from-bridge"}, payloads
        assert (stop, b"stop-from-supervisor") in received and (grip, b"grip-from-gripper") in received
        sub.undeclare()
    finally:
        watcher.close()


def test_ros1_side_commands_only_from_the_bridge(multihost):
    profile, _, _ = multihost
    received: list[bytes] = []
    key = ("6261787465725f636f72655f6d7367732f4a6f696e74436f6d6d616e64/19bfec8434dd568ab3c633d187c36f2e"
           "/robot/limb/right/joint_command")
    robot = open_session(profile, "client", timeout_s=5.0, user="ros1")
    try:
        sub = robot.declare_subscriber(key, lambda s: received.append(s.payload.to_bytes()))
        assert _probe(profile, "motion", [(key, "from-motion")]).returncode == 0
        assert _probe(profile, "bridge", [(key, "from-bridge")]).returncode == 0
        assert wait_until(lambda: b"from-bridge" in received, 5.0)
        assert b"from-motion" not in received
        sub.undeclare()
    finally:
        robot.close()


def test_default_profile_listens_on_loopback_only():
    profile = load_profile_file("sim").with_bus(endpoint=f"tcp/127.0.0.1:{free_tcp_port()}")
    conf = zenoh_config_dict(profile, "router")
    assert conf["listen"]["endpoints"] == [profile.endpoint]
    assert conf["scouting"]["multicast"]["enabled"] is False and conf["scouting"]["gossip"]["enabled"] is False
    assert load_profile_file("sim").endpoint.startswith("tcp/127.0.0.1:")
    port = int(profile.endpoint.rsplit(":", 1)[1])
    me = psutil.Process()
    before = {c.laddr for c in me.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN}
    with BusRouter(profile):
        listening = [c.laddr for c in me.net_connections(kind="inet")
                     if c.status == psutil.CONN_LISTEN and c.laddr not in before]
    assert any(addr.port == port for addr in listening), listening
    assert all(addr.ip in ("127.0.0.1", "::1") for addr in listening), listening


def test_heartbeats_from_every_service_and_the_supervisors_episode_pass(multihost):
    """What the supervisor needs: every service's heartbeat reaches it, its episode summaries
    reach the launcher; only the supervisor may publish them, only the Kinect driver the
    skeleton (each user on its own authenticated session)."""
    profile, _, _ = multihost
    prefix = profile.prefix
    heartbeat, episode, skeleton = (f"{prefix}/runtime/heartbeat", f"{prefix}/supervisor/episode",
                                    f"{prefix}/perception/skeleton")
    at_supervisor: list[tuple[str, bytes]] = []
    at_launcher: list[bytes] = []
    supervisor = open_session(profile, "client", timeout_s=5.0, user="supervisor")
    launcher = open_session(profile, "client", timeout_s=5.0, user="launcher")
    try:
        subs = [supervisor.declare_subscriber(f"{prefix}/**", lambda s: at_supervisor.append(
                    (str(s.key_expr), s.payload.to_bytes()))),
                launcher.declare_subscriber(episode, lambda s: at_launcher.append(s.payload.to_bytes()))]
        time.sleep(0.3)  # let the router learn the subscribers
        puts = [(user, f"{heartbeat}/{user}", f"beat-{user}") for user in USERS if user != "supervisor"]
        # A beat on another service's key (a stranger beating for the planner) is dropped.
        puts += [("gripper", f"{heartbeat}/planner", "beat-for-planner-from-gripper")]
        puts += [("supervisor", episode, "episode-from-supervisor"), ("gripper", episode, "episode-from-gripper"),
                 ("kinect", skeleton, "skeleton-from-kinect"), ("bridge", skeleton, "skeleton-from-bridge")]
        sessions = {user: open_session(profile, "client", timeout_s=5.0, user=user)
                    for user in {u for u, _, _ in puts} - {"supervisor"}}
        sessions["supervisor"] = supervisor
        try:
            time.sleep(0.3)
            for _ in range(10):
                for user, key, payload in puts:
                    sessions[user].put(key, payload.encode())
                time.sleep(0.01)
            beats = {f"beat-{u}".encode() for u in USERS if u != "supervisor"}
            assert wait_until(lambda: {p for _, p in at_supervisor} >= beats | {b"skeleton-from-kinect"}, 5.0), \
                sorted({p for _, p in at_supervisor})
            assert wait_until(lambda: b"episode-from-supervisor" in at_launcher, 5.0), at_launcher
            time.sleep(0.2)
        finally:
            for user, session in sessions.items():
                if user != "supervisor":
                    session.close()
        beat_keys = {k for k, p in at_supervisor if p.startswith(b"beat-")}
        assert beat_keys == {f"{heartbeat}/{u}" for u in USERS if u != "supervisor"}
        assert b"beat-for-planner-from-gripper" not in {p for _, p in at_supervisor}
        assert b"episode-from-gripper" not in at_launcher
        assert b"skeleton-from-bridge" not in {p for _, p in at_supervisor}
        for sub in subs:
            sub.undeclare()
    finally:
        supervisor.close()
        launcher.close()
