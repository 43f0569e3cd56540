"""The Zenoh configuration of every session the stack opens, built from a profile.

Multicast scouting and gossip off; every listen and connect endpoint on loopback unless the
profile allows other interfaces; no message above the bus cap taken in; the logins, the
router's access list and TLS when the profile has them.
"""

from __future__ import annotations

import copy
import json
from typing import Any, Literal

from bus_schema import MAX_PAYLOAD_BYTES
from services.runtime.errors import ProfileError
from services.runtime.profile import Profile, validate_endpoint

#: Largest Zenoh message a session takes in: the bus cap plus key and framing, bytes.
_MAX_MESSAGE_BYTES = MAX_PAYLOAD_BYTES + 65536


def _base_config(mode: str, listen: list[str], connect: list[str]) -> dict[str, Any]:
    return {
        "mode": mode,
        "listen": {"endpoints": listen},
        "connect": {"endpoints": connect},
        "scouting": {
            "multicast": {"enabled": False},
            "gossip": {"enabled": False},
        },
        "transport": {
            "link": {
                # The bus carries at most 1 MiB per message (plus framing).
                "rx": {"max_message_size": _MAX_MESSAGE_BYTES},
            }
        },
    }


def zenoh_config_dict(profile: Profile, mode: Literal["client", "router", "peer"],
                      user: str | None = None) -> dict[str, Any]:
    """The JSON-able Zenoh config for a session of `mode` under `profile`.

    ``router`` listens on the profile's endpoint; ``client`` and ``peer`` connect to it.
    With ``[bus.auth]`` the router checks every client's user/password against the
    credentials file and a client presents `user`'s (a client without a user gets none and
    is refused); with ``[bus.access_control]`` the router enforces the ACL.
    """
    validate_endpoint(profile.endpoint, profile.allow_non_loopback)
    if mode == "router":
        conf = _base_config("router", [profile.endpoint], [])
    elif mode in ("client", "peer"):
        conf = _base_config(mode, [], [profile.endpoint])
    else:
        raise ProfileError(f"unknown Zenoh mode {mode!r}")
    if profile.auth is not None:
        if mode == "router":
            conf["transport"]["auth"] = {"usrpwd": {"dictionary_file": str(profile.auth.checked_file())}}
        elif user is not None:
            conf["transport"]["auth"] = {"usrpwd": {"user": user, "password": profile.auth.password(user)}}
    if mode == "router" and profile.access_control is not None:
        conf["access_control"] = profile.access_control.zenoh_dict(profile.prefix)
    if profile.tls is not None:
        conf["transport"]["link"]["tls"] = profile.tls.zenoh_dict()
    # Copies: the merge below changes nested tables in place.
    access_control, auth, tls = copy.deepcopy((conf.get("access_control"), conf["transport"].get("auth"),
                                               conf["transport"]["link"].get("tls")))
    _deep_merge(conf, profile.zenoh_overrides)
    # Whatever the overrides say, scouting stays off, the logins, the access list and TLS are
    # the profile's own, every endpoint obeys the loopback rule (and is tls/ on a TLS bus) and
    # no message above the bus cap is taken in.
    conf["scouting"]["multicast"]["enabled"] = False
    conf["scouting"]["gossip"]["enabled"] = False
    _restore(conf, "access_control", access_control)
    _restore(conf["transport"], "auth", auth)
    _restore(conf["transport"].setdefault("link", {}), "tls", tls)
    for side in ("listen", "connect"):
        raw = conf.get(side) or {}
        endpoints = raw.get("endpoints", []) if isinstance(raw, dict) else raw
        for endpoint in endpoints if isinstance(endpoints, list) else [endpoints]:
            validate_endpoint(str(endpoint), profile.allow_non_loopback)
            if profile.tls is not None and not str(endpoint).startswith("tls/"):
                raise ProfileError(f"bus endpoint {endpoint!r}: this profile's bus is TLS only ([bus.tls])")
    rx = conf["transport"].setdefault("link", {}).setdefault("rx", {})
    rx["max_message_size"] = min(int(rx.get("max_message_size", _MAX_MESSAGE_BYTES)), _MAX_MESSAGE_BYTES)
    return conf


def zenoh_config(profile: Profile, mode: Literal["client", "router", "peer"], user: str | None = None):
    """A `zenoh.Config` for a session of `mode` (never Zenoh's multicast-scouting default);
    `user` picks the credentials of a client when the profile has ``[bus.auth]``."""
    import zenoh

    try:
        return zenoh.Config.from_json5(json.dumps(zenoh_config_dict(profile, mode, user)))
    except Exception as exc:  # noqa: BLE001 - zenoh.ZError, or our own checks: one ProfileError line either way
        raise ProfileError(f"invalid Zenoh settings in the profile: {exc}") from None


def _restore(table: dict[str, Any], key: str, value: Any) -> None:
    """`table[key]` back to `value` (removed when None), whatever an override made of it."""
    if value is None:
        table.pop(key, None)
    else:
        table[key] = value


def _deep_merge(into: dict[str, Any], other: dict[str, Any]) -> None:
    for key, value in other.items():
        if isinstance(value, dict) and isinstance(into.get(key), dict):
            _deep_merge(into[key], value)
        else:
            into[key] = value
