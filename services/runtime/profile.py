"""Deploy profiles: the bus, the launcher's table and each service, read and checked.

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

Endpoints are on loopback only unless the profile sets ``bus.allow_non_loopback = true``
(multi-host profiles, which must then also configure authentication). The bus's logins and
access list: `services.runtime.bus_access`; TLS: `services.runtime.bus_tls`; the Zenoh
config of a session: `services.runtime.zenoh_config`.
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from bus_schema import DEFAULT_PREFIX
from services.runtime.bus_access import CREDENTIALS_ENV, AccessControl, BusAuth, parse_access_control, parse_auth
from services.runtime.bus_tls import BusTls, parse_tls
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
        nice: CPU niceness the launcher starts it with, 0 (normal) to 19 (lowest priority);
            safety services must stay at 0 so heavy non-critical ones cannot starve them.
        stop_timeout_s: how long the launcher waits after SIGINT before SIGTERM (and as long
            again before SIGKILL), s; None: the launcher's `term_timeout_s`. The recorder
            finalises its file after SIGINT (seconds for a long run).
    """

    name: str
    module: str
    enabled: bool = True
    restart: RestartPolicy = "never"
    max_restarts: int = 0
    safety: bool = False
    args: tuple[str, ...] = ()
    config: dict[str, Any] = field(default_factory=dict)
    nice: int = 0
    stop_timeout_s: float | None = None


NICE_RANGE = (0, 19)


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
        auth: user/password authentication on the bus (``[bus.auth]``), or None.
        access_control: the router's access control list (``[bus.access_control]``), or None.
        logins: ``per-run`` (``handover-up`` makes a login per service for each run, and a
            service finds its own through ``HANDOVER_BUS_CREDENTIALS``:
            `services.launcher.logins`; the default without ``[bus.auth]``) or ``off`` (no
            per-run logins: fixed ones from ``[bus.auth]``, or none at all when said so).
        tls: mutual TLS on the bus (``[bus.tls]``, `services.runtime.bus_tls`), or None.
        fault_injection: ``[testing] fault_injection = true``: the services take
            `HANDOVER_FAULTS` rules (`services.runtime.faults`); fault-test profiles only.
        clock: ``[clock] source``: ``wall`` (default) or ``sim``, the simulation clock that
            the bridge's simulation owns (`services.runtime.clock`; ``HANDOVER_CLOCK``, which
            ``handover-up --clock`` sets, overrides it).
    """

    path: Path | None
    endpoint: str = DEFAULT_ENDPOINT
    prefix: str = DEFAULT_PREFIX
    allow_non_loopback: bool = False
    zenoh_overrides: dict[str, Any] = field(default_factory=dict)
    auth: BusAuth | None = None
    access_control: AccessControl | None = None
    logins: str = "off"
    tls: BusTls | None = None
    fault_injection: bool = False
    clock: str = "wall"
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
        if new.tls is not None and not new.endpoint.startswith("tls/"):
            raise ProfileError(f"{self.path}: this profile's bus is TLS only ([bus.tls]); the endpoint "
                               f"{new.endpoint!r} must be tls/<host>:<port>")
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
            "bus.allow_non_loopback = true (with logins, an access list and TLS) may use other interfaces"
        )


def _as_spec(name: str, table: Any, path: Path) -> ServiceSpec:
    if not isinstance(table, dict):
        raise ProfileError(f"{path}: [services.{name}] must be a table")
    unknown = set(table) - {"module", "enabled", "restart", "max_restarts", "safety", "args", "config", "nice",
                          "stop_timeout_s"}
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
    nice = table.get("nice", 0)
    if isinstance(nice, bool) or not isinstance(nice, int) or not NICE_RANGE[0] <= nice <= NICE_RANGE[1]:
        raise ProfileError(f"{path}: services.{name}.nice must be an integer from {NICE_RANGE[0]} "
                           f"(normal) to {NICE_RANGE[1]} (lowest CPU priority), got {nice!r}")
    stop_timeout_s = table.get("stop_timeout_s")
    if stop_timeout_s is not None and (isinstance(stop_timeout_s, bool) or not isinstance(stop_timeout_s, (int, float))
                                       or not 0.0 < stop_timeout_s <= 600.0):
        raise ProfileError(f"{path}: services.{name}.stop_timeout_s must be a number of seconds in (0, 600], "
                           f"got {stop_timeout_s!r}")
    if nice != 0 and bool(table.get("safety", False)):
        raise ProfileError(f"{path}: services.{name}.nice = {nice}, but {name} is a safety service: "
                           "it must keep nice = 0 so that heavy services cannot starve it")
    return ServiceSpec(
        name=name,
        module=str(table.get("module", f"services.{name}")),
        enabled=bool(table.get("enabled", True)),
        restart=restart,
        max_restarts=max_restarts,
        safety=bool(table.get("safety", False)),
        args=tuple(args),
        config=config,
        nice=nice,
        stop_timeout_s=None if stop_timeout_s is None else float(stop_timeout_s),
    )


#: Zenoh settings a profile's ``[bus.zenoh]`` may not set: the bus's logins, access list and
#: TLS come only from ``[bus.auth]``, ``[bus.access_control]``, ``[bus.tls]`` and the launcher,
#: and no plugin or admin space is opened.
_GUARDED_OVERRIDES = ("access_control", "plugins", "plugins_loading", "adminspace")
_GUARDED_TRANSPORT = ("auth",)


def _check_overrides(overrides: dict[str, Any], path: Path) -> None:
    for key in _GUARDED_OVERRIDES:
        if key in overrides:
            raise ProfileError(f"{path}: [bus.zenoh] may not set {key} (the bus's security comes from [bus.*])")
    transport = overrides.get("transport", {})
    if not isinstance(transport, dict) or any(k in transport for k in _GUARDED_TRANSPORT) \
            or "tls" in (transport.get("link", {}) if isinstance(transport.get("link"), dict) else {}):
        raise ProfileError(f"{path}: [bus.zenoh.transport] may not set auth or link.tls "
                           "(use [bus.auth] and [bus.tls])")
    for side in ("listen", "connect"):
        if side in overrides and not isinstance(overrides[side], dict):
            raise ProfileError(f"{path}: [bus.zenoh.{side}] must be a table: {side} = {{ endpoints = [...] }}")


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
    auth = parse_auth(bus.get("auth"), path)
    tls = parse_tls(bus.get("tls"), path, endpoint)
    access_control = parse_access_control(bus.get("access_control"), path)
    if allow and (auth is None or access_control is None or tls is None):
        raise ProfileError(f"{path}: bus.allow_non_loopback = true needs [bus.auth] (user/password per service), "
                           "[bus.access_control] and [bus.tls] (mutual TLS): a bus other hosts reach is never open")
    _check_overrides(overrides, path)
    for side in ("listen", "connect"):  # the Zenoh overrides obey the loopback rule too, checked at load
        endpoints = overrides.get(side, {}).get("endpoints", [])
        for endpoint in endpoints if isinstance(endpoints, list) else [endpoints]:
            try:
                validate_endpoint(endpoint, allow)
            except ProfileError as exc:
                raise ProfileError(f"{path}: [bus.zenoh.{side}] {exc}") from None
    if access_control is not None and auth is None:
        raise ProfileError(f"{path}: [bus.access_control] names users, so it needs [bus.auth]")
    # Authenticated by default: per-run logins, unless the profile has fixed ones ([bus.auth]).
    logins = bus.get("logins", "off" if auth is not None else "per-run")
    if logins not in ("per-run", "off"):
        raise ProfileError(f"{path}: bus.logins must be \"per-run\" or \"off\", not {logins!r}")
    if logins == "per-run" and auth is not None:
        raise ProfileError(f"{path}: bus.logins = \"per-run\" and [bus.auth] exclude each other")
    if logins == "per-run" and os.environ.get(CREDENTIALS_ENV):
        auth = BusAuth(Path(os.environ[CREDENTIALS_ENV]))  # a service of a run: its own login
    testing = doc.get("testing", {})
    if not isinstance(testing, dict) or set(testing) - {"fault_injection"} \
            or not isinstance(testing.get("fault_injection", False), bool):
        raise ProfileError(f"{path}: [testing] may hold only fault_injection = true/false")
    clock = doc.get("clock", {})
    if not isinstance(clock, dict) or set(clock) - {"source"} or clock.get("source", "wall") not in ("wall", "sim"):
        raise ProfileError(f"{path}: [clock] may hold only source = \"wall\" or \"sim\"")
    services = tuple(_as_spec(name, table, path) for name, table in services_table.items())
    return Profile(
        path=path,
        endpoint=endpoint,
        prefix=prefix,
        allow_non_loopback=allow,
        zenoh_overrides=overrides,
        auth=auth,
        access_control=access_control,
        logins=logins,
        tls=tls,
        fault_injection=testing.get("fault_injection", False),
        clock=clock.get("source", "wall"),
        services=services,
        launcher=dict(doc.get("launcher", {})),
        raw=doc,
    )
