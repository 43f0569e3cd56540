"""Deploy profiles and the Zenoh configs built from them."""

from __future__ import annotations

from pathlib import Path

import pytest

from bus_schema import MAX_PAYLOAD_BYTES
from services.runtime.errors import ProfileError
from services.runtime.profile import load_profile_file, validate_endpoint
from services.runtime.zenoh_config import zenoh_config, zenoh_config_dict


def test_default_profile_is_loopback_with_scouting_off():
    profile = load_profile_file("sim")
    assert profile.endpoint.startswith("tcp/127.0.0.1:")
    assert profile.prefix == "handover/v1"
    for mode in ("client", "router", "peer"):
        conf = zenoh_config_dict(profile, mode)
        assert conf["scouting"]["multicast"]["enabled"] is False
        assert conf["scouting"]["gossip"]["enabled"] is False
        endpoints = conf["listen"]["endpoints"] + conf["connect"]["endpoints"]
        assert endpoints == [profile.endpoint]
        zenoh_config(profile, mode)  # Zenoh itself accepts it


def test_router_listens_clients_connect():
    profile = load_profile_file("sim")
    assert zenoh_config_dict(profile, "router")["listen"]["endpoints"] == [profile.endpoint]
    assert zenoh_config_dict(profile, "router")["connect"]["endpoints"] == []
    assert zenoh_config_dict(profile, "client")["listen"]["endpoints"] == []


def test_overrides_cannot_turn_scouting_on(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text('[bus]\nendpoint = "tcp/127.0.0.1:7999"\n'
                    '[bus.zenoh.scouting.multicast]\nenabled = true\n')
    conf = zenoh_config_dict(load_profile_file(path), "client")
    assert conf["scouting"]["multicast"]["enabled"] is False


@pytest.mark.parametrize("endpoint", ["tcp/0.0.0.0:7447", "tcp/192.168.1.10:7447", "tcp/[::]:7447"])
def test_non_loopback_endpoints_refused(endpoint):
    with pytest.raises(ProfileError, match="not on loopback"):
        validate_endpoint(endpoint)
    validate_endpoint(endpoint.replace("[::]", "[::1]").replace("0.0.0.0", "127.0.0.1")
                      .replace("192.168.1.10", "127.0.0.1"))


@pytest.mark.parametrize("endpoint", ["127.0.0.1:7447", "tcp/127.0.0.1", "tcp/127.0.0.1:99999", "ftp/127.0.0.1:1"])
def test_malformed_endpoints_refused(endpoint):
    with pytest.raises(ProfileError):
        validate_endpoint(endpoint)


def test_with_bus_validates_overrides():
    profile = load_profile_file("sim")
    assert profile.with_bus("tcp/127.0.0.1:9000").endpoint == "tcp/127.0.0.1:9000"
    with pytest.raises(ProfileError):
        profile.with_bus("tcp/10.0.0.1:9000")


@pytest.mark.parametrize("text,match", [
    ("[bus\n", "invalid TOML"),
    ('[bus]\nprefix = "a/*"\n', "prefix"),
    ('[services.bridge]\nrestart = "always"\n', "restart"),
    ('[services.bridge]\ncolour = "red"\n', "unknown keys"),
    ('[services.bridge]\nargs = "x"\n', "args"),
])
def test_invalid_profiles_name_the_problem(tmp_path, text, match):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ProfileError, match=match):
        load_profile_file(path)


def test_missing_profile_lists_known_ones():
    with pytest.raises(ProfileError, match="known: .*sim"):
        load_profile_file("no-such-profile")


def test_service_specs_from_profile():
    profile = load_profile_file("sim")
    bridge = profile.service("bridge")
    assert bridge is not None and bridge.safety and bridge.restart == "never"
    assert profile.service_config("bridge")["command_timeout_s"] == 0.2
    assert profile.service_config("nobody") == {}


@pytest.mark.parametrize("side", ["listen", "connect"])
def test_overrides_cannot_open_a_non_loopback_endpoint(tmp_path, side):
    path = tmp_path / "p.toml"
    path.write_text(f'[bus]\nendpoint = "tcp/127.0.0.1:7999"\n[bus.zenoh.{side}]\nendpoints = ["tcp/0.0.0.0:7999"]\n')
    with pytest.raises(ProfileError, match=rf"p.toml: \[bus.zenoh.{side}\] .*not on loopback"):
        load_profile_file(path)  # refused at load, before anything starts
    # and a profile built in code with such an override is refused when a session is configured
    from dataclasses import replace

    profile = replace(load_profile_file("sim"), zenoh_overrides={side: {"endpoints": ["tcp/0.0.0.0:7999"]}})
    with pytest.raises(ProfileError, match="not on loopback"):
        zenoh_config_dict(profile, "router")


def test_overrides_cannot_raise_the_message_size_cap(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text('[bus]\nendpoint = "tcp/127.0.0.1:7999"\n'
                    '[bus.zenoh.transport.link.rx]\nmax_message_size = 1073741824\n')
    conf = zenoh_config_dict(load_profile_file(path), "client")
    assert conf["transport"]["link"]["rx"]["max_message_size"] == MAX_PAYLOAD_BYTES + 65536
    path.write_text('[bus]\nendpoint = "tcp/127.0.0.1:7999"\n[bus.zenoh.transport.link.rx]\nmax_message_size = 4096\n')
    assert zenoh_config_dict(load_profile_file(path), "client")["transport"]["link"]["rx"]["max_message_size"] == 4096


def test_a_service_may_have_its_own_stop_time_out(tmp_path):
    assert load_profile_file("sim").service("recorder").stop_timeout_s == 60.0
    assert load_profile_file("sim").service("bridge").stop_timeout_s is None  # the launcher's term_timeout_s
    path = tmp_path / "p.toml"
    for bad in ("0", "-1", "true", '"60"', "601"):
        path.write_text(f'[bus]\nendpoint = "tcp/127.0.0.1:7999"\n[services.recorder]\nstop_timeout_s = {bad}\n')
        with pytest.raises(ProfileError, match="stop_timeout_s must be a number of seconds"):
            load_profile_file(path)



@pytest.mark.parametrize(("table", "says"), [
    ("[bus.zenoh.access_control]\nenabled = false\n", "may not set access_control"),
    ("[bus.zenoh.transport.auth.usrpwd]\ndictionary_file = \"/tmp/x\"\n", "may not set auth or link.tls"),
    ("[bus.zenoh.transport.link.tls]\nenable_mtls = false\n", "may not set auth or link.tls"),
    ("[bus.zenoh.plugins.rest]\nhttp_port = 8000\n", "may not set plugins"),
    ("[bus.zenoh]\nlisten = [\"tcp/0.0.0.0:7999\"]\n", "must be a table"),
])
def test_zenoh_overrides_cannot_touch_the_bus_security(tmp_path, table, says):
    """The logins, the access list and TLS come only from [bus.*] (issue 17)."""
    path = tmp_path / "p.toml"
    path.write_text('[bus]\nendpoint = "tcp/127.0.0.1:7999"\n' + table)
    with pytest.raises(ProfileError, match=says) as info:
        load_profile_file(path)
    assert "\n" not in str(info.value)


def test_a_profile_in_code_cannot_override_the_access_list_either():
    from dataclasses import replace

    from services.runtime.bus_access import AccessControl, BusAuth

    base = load_profile_file("sim")
    profile = replace(base, auth=BusAuth(Path("/nonexistent"), env_override=False), access_control=AccessControl(),
                      zenoh_overrides={"access_control": {"enabled": False}})
    with pytest.raises(ProfileError, match="not found"):  # the dictionary is checked, the list is the profile's
        zenoh_config_dict(profile, "router")
    no_auth = replace(base, access_control=AccessControl(), zenoh_overrides={"access_control": {"enabled": False}})
    assert zenoh_config_dict(no_auth, "router")["access_control"]["enabled"] is True



def test_an_access_list_user_must_be_one_key_chunk(tmp_path):
    creds = tmp_path / "creds"
    creds.write_text("x:y\n")
    creds.chmod(0o600)
    path = tmp_path / "p.toml"
    path.write_text(f'[bus]\nendpoint = "tcp/127.0.0.1:7999"\n[bus.auth]\ncredentials_file = "{creds}"\n'
                    '[bus.access_control]\n[bus.access_control.users."*"]\npublish = ["a/b"]\n')
    with pytest.raises(ProfileError, match="must not hold"):  # "*" would own every heartbeat key
        load_profile_file(path)
