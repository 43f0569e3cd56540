"""Deploy profiles and the Zenoh configurations built from them.

A profile is a TOML file under `deploy/` (``deploy/sim.toml`` is the default). It names the
bus endpoint, the key prefix and, per service, how to run it and its own config table:

```toml
[bus]
endpoint = "tcp/127.0.0.1:7447"   # where the launcher's router listens; services connect
prefix = "handover/v1"

[services.bridge]
module = "services.bridge"         # run as `python -m <module>`
restart = "never"                  # never | on-failure
[services.bridge.config]           # the service's own typed config
backend = "sim"
```

Every Zenoh session the stack opens is built here: multicast scouting and gossip off, and
endpoints on loopback only unless the profile sets ``bus.allow_non_loopback = true``
(multi-host profiles, which must then also configure authentication).
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from bus_schema import DEFAULT_PREFIX, MAX_PAYLOAD_BYTES
from services.runtime.errors import ProfileError

REPO_ROOT = Path(__file__).resolve().parents[2]
DEPLOY_DIR = REPO_ROOT / "deploy"
DEFAULT_PROFILE = "sim"
DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"

RestartPolicy = Literal["never", "on-failure"]
_LOOPBACK_HOSTS = ("127.0.0.1", "[::1]", "localhost")


@dataclass(frozen=True)
class ServiceSpec:
    """How the launcher runs one service.

    Attributes:
        name: service name (also its liveliness token and log prefix).
        module: Python module run as ``python -m module``.
        enabled: start it with the stack.
        restart: ``never`` or ``on-failure``.
        max_restarts: restarts allowed per run when ``on-failure``.
        safety: a safety service (never restarted mid-episode, whatever `restart` says).
        args: extra command-line arguments.
        config: the service's own config table (a dict for its typed config).
    """

    name: str
    module: str
    enabled: bool = True
    restart: RestartPolicy = "never"
    max_restarts: int = 0
    safety: bool = False
    args: tuple[str, ...] = ()
    config: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Profile:
    """A loaded deploy profile.

    Attributes:
        path: the TOML file it came from (None when built in code).
        endpoint: Zenoh endpoint of the router, e.g. ``tcp/127.0.0.1:7447``.
        prefix: key prefix, e.g. ``handover/v1``.
        allow_non_loopback: permit endpoints off loopback (multi-host profiles only).
        zenoh_overrides: extra JSON5 settings inserted into every session's config.
        services: the services, in start order.
        launcher: the launcher's own table.
        raw: the whole parsed document.
    """

    path: Path | None
    endpoint: str = DEFAULT_ENDPOINT
    prefix: str = DEFAULT_PREFIX
    allow_non_loopback: bool = False
    zenoh_overrides: dict[str, Any] = field(default_factory=dict)
    services: tuple[ServiceSpec, ...] = ()
    launcher: dict[str, Any] = field(default_factory=dict)
    raw: dict[str, Any] = field(default_factory=dict)

    def service(self, name: str) -> ServiceSpec | None:
        """The spec of service `name`, or None when the profile does not list it."""
        for spec in self.services:
            if spec.name == name:
                return spec
        return None

    def service_config(self, name: str) -> dict[str, Any]:
        """The ``[services.<name>.config]`` table ({} when absent)."""
        spec = self.service(name)
        return dict(spec.config) if spec else {}

    def with_bus(self, endpoint: str | None = None, prefix: str | None = None) -> Profile:
        """A copy with the endpoint and/or prefix replaced (CLI overrides)."""
        from dataclasses import replace

        new = replace(
            self,
            endpoint=endpoint if endpoint else self.endpoint,
            prefix=prefix if prefix else self.prefix,
        )
        validate_endpoint(new.endpoint, new.allow_non_loopback)
        return new


def free_tcp_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago (for `--port auto` and tests)."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def resolve_profile_path(profile: str | Path) -> Path:
    """A profile name (``sim``) or a path to a TOML file, as an existing path."""
    candidate = Path(profile)
    if candidate.suffix == ".toml" or candidate.exists():
        path = candidate
    else:
        path = DEPLOY_DIR / f"{profile}.toml"
    if not path.is_file():
        known = sorted(p.stem for p in DEPLOY_DIR.glob("*.toml")) if DEPLOY_DIR.is_dir() else []
        raise ProfileError(f"profile {str(profile)!r} not found (looked for {path}); known: {known}")
    return path


def validate_endpoint(endpoint: str, allow_non_loopback: bool = False) -> None:
    """Refuse endpoints that are not `tcp/<loopback>:<port>` (unless multi-host is allowed)."""
    if not isinstance(endpoint, str) or "/" not in endpoint:
        raise ProfileError(f"bus endpoint {endpoint!r} is not of the form tcp/127.0.0.1:<port>")
    proto, _, address = endpoint.partition("/")
    host, _, port = address.rpartition(":")
    if proto not in ("tcp", "tls", "quic", "udp") or not port.isdigit() or not host:
        raise ProfileError(f"bus endpoint {endpoint!r} is not of the form tcp/127.0.0.1:<port>")
    if not 0 < int(port) < 65536:
        raise ProfileError(f"bus endpoint {endpoint!r} has port {port}, outside 1–65535")
    if not allow_non_loopback and host not in _LOOPBACK_HOSTS:
        raise ProfileError(
            f"bus endpoint {endpoint!r} is not on loopback; only a multi-host profile with "
            "bus.allow_non_loopback = true (and authentication) may use other interfaces"
        )


def _as_spec(name: str, table: Any, path: Path) -> ServiceSpec:
    if not isinstance(table, dict):
        raise ProfileError(f"{path}: [services.{name}] must be a table")
    unknown = set(table) - {"module", "enabled", "restart", "max_restarts", "safety", "args", "config"}
    if unknown:
        raise ProfileError(f"{path}: [services.{name}] has unknown keys {sorted(unknown)}")
    restart = table.get("restart", "never")
    if restart not in ("never", "on-failure"):
        raise ProfileError(f"{path}: services.{name}.restart must be 'never' or 'on-failure'")
    args = table.get("args", [])
    config = table.get("config", {})
    max_restarts = table.get("max_restarts", 3 if restart == "on-failure" else 0)
    if not isinstance(args, list) or not all(isinstance(a, str) for a in args):
        raise ProfileError(f"{path}: services.{name}.args must be a list of strings")
    if not isinstance(config, dict):
        raise ProfileError(f"{path}: services.{name}.config must be a table")
    if not isinstance(max_restarts, int) or max_restarts < 0:
        raise ProfileError(f"{path}: services.{name}.max_restarts must be a non-negative integer")
    return ServiceSpec(
        name=name,
        module=str(table.get("module", f"services.{name}")),
        enabled=bool(table.get("enabled", True)),
        restart=restart,
        max_restarts=max_restarts,
        safety=bool(table.get("safety", False)),
        args=tuple(args),
        config=config,
    )


def load_profile_file(profile: str | Path = DEFAULT_PROFILE) -> Profile:
    """Load and validate a deploy profile by name or path.

    Raises:
        ProfileError: missing file, TOML syntax error, or invalid values (the message names
            the file and the key).
    """
    path = resolve_profile_path(profile)
    try:
        doc = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(f"{path}: invalid TOML: {exc}") from None
    bus = doc.get("bus", {})
    if not isinstance(bus, dict):
        raise ProfileError(f"{path}: [bus] must be a table")
    services_table = doc.get("services", {})
    if not isinstance(services_table, dict):
        raise ProfileError(f"{path}: [services] must be a table of tables")
    prefix = bus.get("prefix", DEFAULT_PREFIX)
    if not isinstance(prefix, str) or not prefix or any(c in prefix for c in "*$?#") or prefix.endswith("/"):
        raise ProfileError(f"{path}: bus.prefix {prefix!r} must be a plain key like 'handover/v1'")
    allow = bool(bus.get("allow_non_loopback", False))
    endpoint = bus.get("endpoint", DEFAULT_ENDPOINT)
    validate_endpoint(endpoint, allow)
    overrides = bus.get("zenoh", {})
    if not isinstance(overrides, dict):
        raise ProfileError(f"{path}: [bus.zenoh] must be a table")
    return Profile(
        path=path,
        endpoint=endpoint,
        prefix=prefix,
        allow_non_loopback=allow,
        zenoh_overrides=overrides,
        services=tuple(_as_spec(name, table, path) for name, table in services_table.items()),
        launcher=dict(doc.get("launcher", {})),
        raw=doc,
    )


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
                "rx": {"max_message_size": MAX_PAYLOAD_BYTES + 65536},
            }
        },
    }


def zenoh_config_dict(profile: Profile, mode: Literal["client", "router", "peer"]) -> dict[str, Any]:
    """The JSON-able Zenoh config for a session of `mode` under `profile`.

    ``router`` listens on the profile's endpoint; ``client`` and ``peer`` connect to it.
    """
    validate_endpoint(profile.endpoint, profile.allow_non_loopback)
    if mode == "router":
        conf = _base_config("router", [profile.endpoint], [])
    elif mode in ("client", "peer"):
        conf = _base_config(mode, [], [profile.endpoint])
    else:
        raise ProfileError(f"unknown Zenoh mode {mode!r}")
    _deep_merge(conf, profile.zenoh_overrides)
    # Whatever the overrides say, scouting stays off.
    conf["scouting"]["multicast"]["enabled"] = False
    conf["scouting"]["gossip"]["enabled"] = False
    return conf


def zenoh_config(profile: Profile, mode: Literal["client", "router", "peer"]):
    """A `zenoh.Config` for a session of `mode` (never Zenoh's multicast-scouting default)."""
    import zenoh

    try:
        return zenoh.Config.from_json5(json.dumps(zenoh_config_dict(profile, mode)))
    except Exception as exc:  # zenoh raises ZError
        raise ProfileError(f"invalid Zenoh settings in the profile: {exc}") from None


def _deep_merge(into: dict[str, Any], other: dict[str, Any]) -> None:
    for key, value in other.items():
        if isinstance(value, dict) and isinstance(into.get(key), dict):
            _deep_merge(into[key], value)
        else:
            into[key] = value
