"""Deploy-profile authentication and access control: parsing, refusals, generated Zenoh config."""

from __future__ import annotations

import pytest

from services.launcher.certs import make_certificates
from services.runtime.errors import ProfileError
from services.runtime.profile import load_profile_file
from services.runtime.zenoh_config import zenoh_config, zenoh_config_dict

BASE = """
[bus]
endpoint = "{endpoint}"
allow_non_loopback = {allow}
{extra}
"""

TLS = """
[bus.tls]
ca_file = "tls/ca.pem"
cert_file = "tls/10.0.0.2.pem"
key_file = "tls/10.0.0.2.key"
"""

AUTH = """
[bus.auth]
credentials_file = "creds"
[bus.access_control]
[bus.access_control.users.supervisor]
publish = ["{prefix}/motion/stop"]
subscribe = ["{prefix}/**"]
[bus.access_control.users.recorder]
subscribe = ["{prefix}/**"]
"""


def _profile(tmp_path, endpoint="tls/10.0.0.2:7447", allow="true", extra=AUTH + TLS,
             creds="supervisor:s\nrecorder:r\n", mode=0o600):
    if not (tmp_path / "tls").exists():
        make_certificates(tmp_path / "tls", ["10.0.0.2"])
    (tmp_path / "creds").write_text(creds)
    (tmp_path / "creds").chmod(mode)
    path = tmp_path / "p.toml"
    path.write_text(BASE.format(endpoint=endpoint, allow=allow, extra=extra))
    return load_profile_file(path)


def test_non_loopback_needs_auth(tmp_path):
    for missing in ("", AUTH, TLS):  # logins, access list and TLS: all three, or no other host
        with pytest.raises(ProfileError, match="needs \\[bus.auth\\].*\\[bus.access_control\\] and \\[bus.tls\\]"):
            _profile(tmp_path, endpoint="tls/10.0.0.2:7447" if "bus.tls" in missing else "tcp/10.0.0.2:7447",
                     extra=missing)
    with pytest.raises(ProfileError, match="not on loopback"):
        _profile(tmp_path, endpoint="tcp/10.0.0.2:7447", allow="false", extra="")


def test_router_gets_dictionary_and_deny_by_default_acl(tmp_path, monkeypatch):
    monkeypatch.delenv("HANDOVER_BUS_CREDENTIALS", raising=False)
    profile = _profile(tmp_path)
    router = zenoh_config_dict(profile, "router")
    assert router["transport"]["auth"]["usrpwd"]["dictionary_file"] == str(tmp_path / "creds")
    acl = router["access_control"]
    assert acl["enabled"] is True and acl["default_permission"] == "deny"
    rules = {r["id"]: r for r in acl["rules"]}
    assert rules["supervisor_publish"]["key_exprs"] == ["handover/v1/motion/stop",
                                                        "handover/v1/runtime/heartbeat/supervisor"]
    assert rules["supervisor_publish"]["flows"] == ["ingress"]
    assert rules["recorder_receive"]["flows"] == ["egress"]
    assert rules["recorder_publish"]["key_exprs"] == ["handover/v1/runtime/heartbeat/recorder"]  # its beat only
    assert rules["recorder_token"]["key_exprs"] == ["handover/v1/alive/recorder"]
    assert {p["subjects"][0] for p in acl["policies"]} == {"supervisor", "recorder"}
    client = zenoh_config_dict(profile, "client", user="supervisor")
    assert client["transport"]["auth"]["usrpwd"] == {"user": "supervisor", "password": "s"}
    assert "access_control" not in client
    zenoh_config(profile, "router")  # Zenoh itself accepts the generated ACL


def test_credentials_problems_are_clear(tmp_path, monkeypatch):
    monkeypatch.delenv("HANDOVER_BUS_CREDENTIALS", raising=False)
    with pytest.raises(ProfileError, match="chmod 600"):
        zenoh_config_dict(_profile(tmp_path, mode=0o644), "router")
    with pytest.raises(ProfileError, match="no password for user 'motion'"):
        zenoh_config_dict(_profile(tmp_path), "client", user="motion")
    other = tmp_path / "elsewhere"
    other.write_text("motion:m\n")
    other.chmod(0o600)
    monkeypatch.setenv("HANDOVER_BUS_CREDENTIALS", str(other))
    conf = zenoh_config_dict(_profile(tmp_path), "client", user="motion")
    assert conf["transport"]["auth"]["usrpwd"]["password"] == "m"


def test_shipped_profiles_load_and_sim_stays_loopback_without_auth():
    sim = load_profile_file("sim")
    assert sim.auth is None and sim.access_control is None and not sim.allow_non_loopback
    multi = load_profile_file("multihost")
    assert multi.allow_non_loopback and multi.auth is not None
    owners = {name for name, perms in multi.access_control.users.items()
              if any(k.endswith("/motion/stop") for k in perms.publish)}
    # The launcher stops the arm when the supervisor falls silent, the bridge when it dies.
    assert owners == {"supervisor", "launcher", "bridge"}
    for key, owner in (("gripper/command", "gripper"), ("robot/joint_command", "motion")):
        assert {n for n, p in multi.access_control.users.items()
                if any(k == "{prefix}/" + key for k in p.publish)} == {owner}
    assert load_profile_file("baxter").service("bridge").module == "services.bridge.baxter"
