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
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from bus_schema import DEFAULT_PREFIX, MAX_PAYLOAD_BYTES
from bus_schema.topics import HEARTBEAT
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


CREDENTIALS_ENV = "HANDOVER_BUS_CREDENTIALS"
_ACL_PERMISSIONS = ("allow", "deny")


@dataclass(frozen=True)
class BusAuth:
    """User/password authentication on the bus (``[bus.auth]``).

    The credentials file is Zenoh's usrpwd dictionary: one ``user:password`` line per user
    (services authenticate with their own name as the user). The router reads the whole
    file; a client reads its own line. The file must not be readable by group or others.
    The environment variable ``HANDOVER_BUS_CREDENTIALS`` overrides the path, so each host
    can keep its file outside the repository.

    Attributes:
        credentials_file: the file named in the profile (relative to the profile's folder).
    """

    credentials_file: Path

    def checked_file(self) -> Path:
        """The credentials file in use (env override first), checked to exist and be private.

        Raises:
            ProfileError: missing, or readable by group/others.
        """
        import os

        path = Path(os.environ.get(CREDENTIALS_ENV) or self.credentials_file).expanduser()
        if not path.is_file():
            raise ProfileError(f"bus credentials file {path} not found (set [bus.auth].credentials_file "
                               f"or {CREDENTIALS_ENV}; one 'user:password' line per service)")
        if path.stat().st_mode & 0o077:
            raise ProfileError(f"bus credentials file {path} is readable by others: chmod 600 {path}")
        return path

    def users(self) -> dict[str, str]:
        """user → password, from the file."""
        path = self.checked_file()
        out: dict[str, str] = {}
        for line_no, line in enumerate(path.read_text().splitlines(), 1):
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            user, sep, password = line.partition(":")
            if not sep or not user or not password:
                raise ProfileError(f"{path} line {line_no}: expected 'user:password'")
            out[user] = password
        return out

    def password(self, user: str) -> str:
        """`user`'s password. Raises ProfileError when the file has no line for it."""
        users = self.users()
        if user not in users:
            raise ProfileError(f"bus credentials file has no password for user {user!r} "
                               f"(add a '{user}:<password>' line)")
        return users[user]


@dataclass(frozen=True)
class UserPermissions:
    """What one bus user may do (``[bus.access_control.users.<name>]``).

    Key expressions may use ``{prefix}`` for the profile's key prefix.

    Attributes:
        publish: key expressions it may put on.
        subscribe: key expressions it may subscribe to (and receive).
        query: key expressions it may query and declare queryables on.
    """

    publish: tuple[str, ...] = ()
    subscribe: tuple[str, ...] = ()
    query: tuple[str, ...] = ()


@dataclass(frozen=True)
class AccessControl:
    """The router's access control list (``[bus.access_control]``), deny by default.

    Every authenticated user may also declare its own liveliness token
    (``{prefix}/alive/<user>``), watch and query the others', and publish its own heartbeat
    (``{prefix}/runtime/heartbeat/<user>``: a user can beat for nobody else, so a heartbeat's
    sender is its login); everything else needs a ``publish``/``subscribe``/``query`` entry.

    Attributes:
        default_permission: ``deny`` (anything not allowed below is dropped) or ``allow``.
        users: user name → permissions.
        common_publish: key expressions every user may put on (none by default).
    """

    default_permission: str = "deny"
    users: dict[str, UserPermissions] = field(default_factory=dict)
    common_publish: tuple[str, ...] = ()

    def zenoh_dict(self, prefix: str) -> dict[str, Any]:
        """The ``access_control`` section of the router's Zenoh config."""

        def expand(keys: tuple[str, ...]) -> list[str]:
            return [k.replace("{prefix}", prefix) for k in keys]

        alive = f"{prefix}/alive/**"
        rules: list[dict[str, Any]] = [
            {"id": "liveliness_watch", "permission": "allow", "flows": ["ingress"],
             "messages": ["declare_liveliness_subscriber", "liveliness_query"], "key_exprs": [alive]},
            {"id": "liveliness_see", "permission": "allow", "flows": ["egress"],
             "messages": ["liveliness_token", "declare_liveliness_subscriber", "reply"], "key_exprs": [alive]},
        ]
        subjects: list[dict[str, Any]] = []
        policies: list[dict[str, Any]] = []
        for name, perms in sorted(self.users.items()):
            ids: list[str] = ["liveliness_watch", "liveliness_see"]
            publish = expand(perms.publish) + [HEARTBEAT.sender_key(name, prefix)] + expand(self.common_publish)
            candidates = (
                ("token", ["ingress"], ["liveliness_token"], [f"{prefix}/alive/{name}"]),
                ("publish", ["ingress"], ["put", "delete"], publish),
                # A declared publisher sends only once it knows of a matching subscriber; a
                # subscription to a wildcard (every service's heartbeat) is wider than any one
                # publish key, so the publisher is told of every subscription under the prefix.
                ("see_subscribers", ["egress"], ["declare_subscriber"], [f"{prefix}/**", *publish] if publish else []),
                ("subscribe", ["ingress"], ["declare_subscriber"], expand(perms.subscribe)),
                ("receive", ["egress"], ["put", "delete"], expand(perms.subscribe)),
                ("query", ["ingress"], ["query", "declare_queryable"], expand(perms.query)),
                ("query_replies", ["egress"], ["reply", "query"], expand(perms.query)),
            )
            for kind, flows, messages, keys in candidates:
                if keys:
                    rule_id = f"{name}_{kind}"
                    rules.append({"id": rule_id, "permission": "allow", "flows": flows,
                                  "messages": messages, "key_exprs": keys})
                    ids.append(rule_id)
            subjects.append({"id": name, "usernames": [name]})
            policies.append({"id": f"{name}_policy", "rules": ids, "subjects": [name]})
        return {"enabled": True, "default_permission": self.default_permission,
                "rules": rules, "subjects": subjects, "policies": policies}


def _parse_auth(table: Any, path: Path) -> BusAuth | None:
    if table is None:
        return None
    if not isinstance(table, dict) or set(table) - {"credentials_file"} or "credentials_file" not in table:
        raise ProfileError(f"{path}: [bus.auth] must hold exactly credentials_file = \"<path>\"")
    file = table["credentials_file"]
    if not isinstance(file, str) or not file:
        raise ProfileError(f"{path}: bus.auth.credentials_file must be a path")
    resolved = Path(file).expanduser()
    if not resolved.is_absolute():
        resolved = path.parent / resolved
    return BusAuth(resolved)


def _key_list(value: Any, where: str, path: Path) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(k, str) and k for k in value):
        raise ProfileError(f"{path}: {where} must be a list of key expressions")
    return tuple(value)


def _parse_access_control(table: Any, path: Path) -> AccessControl | None:
    if table is None:
        return None
    if not isinstance(table, dict):
        raise ProfileError(f"{path}: [bus.access_control] must be a table")
    unknown = set(table) - {"enabled", "default_permission", "users", "common_publish"}
    if unknown:
        raise ProfileError(f"{path}: [bus.access_control] has unknown keys {sorted(unknown)}")
    if not table.get("enabled", True):
        return None
    default = table.get("default_permission", "deny")
    if default not in _ACL_PERMISSIONS:
        raise ProfileError(f"{path}: bus.access_control.default_permission must be 'deny' or 'allow'")
    users_table = table.get("users", {})
    if not isinstance(users_table, dict) or not users_table:
        raise ProfileError(f"{path}: [bus.access_control.users.<name>] tables are missing")
    users: dict[str, UserPermissions] = {}
    for name, perms in users_table.items():
        if not isinstance(perms, dict) or set(perms) - {"publish", "subscribe", "query"}:
            raise ProfileError(f"{path}: [bus.access_control.users.{name}] may hold publish, subscribe, query")
        users[name] = UserPermissions(
            **{k: _key_list(v, f"bus.access_control.users.{name}.{k}", path) for k, v in perms.items()})
    common = _key_list(table.get("common_publish", []),
                       "bus.access_control.common_publish", path)
    return AccessControl(default, users, common)


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
            `services.launcher.logins`) or ``off``.
        tls: mutual TLS on the bus (``[bus.tls]``, `services.runtime.bus_tls`), or None.
        fault_injection: ``[testing] fault_injection = true``: the services take
            `HANDOVER_FAULTS` rules (`services.runtime.faults`); fault-test profiles only.
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


def _check_niced_services_are_report_only(services: tuple[ServiceSpec, ...], path: Path) -> None:
    """A service the supervisor watches as critical must keep nice = 0.

    The supervisor makes a protective stop when a critical service's heartbeat is 0.25 s old.
    The heartbeat thread needs its process's GIL; in a niced process the main thread that holds
    it is preempted more often and for longer, so a live service falls silent that long (three
    false stops blamed the nice-5 tracker, docs/launcher_perf.md "Why these priorities"). Only services whose
    loss is reported (``watch = "report"``, e.g. the recorder) may be niced."""
    supervisor = next((s for s in services if s.name == "supervisor" and s.enabled), None)
    if supervisor is None:
        return
    from services.supervisor.config import parse_config  # the supervisor owns the watch table
    from services.supervisor.errors import SupervisorConfigError

    # Only the watch table: another bad key (which the supervisor's CLI may override) must not
    # switch this check off.
    table = supervisor.config
    try:
        watch = parse_config({"watch": table["watch"]} if "watch" in table else {}).watch
    except SupervisorConfigError:
        return  # a bad watch table: the supervisor's own config check names it when it starts
    for spec in services:
        if spec.nice != 0 and spec.enabled and watch.get(spec.name, "critical") != "report":
            raise ProfileError(
                f"{path}: services.{spec.name}.nice = {spec.nice}, but the supervisor watches {spec.name} as "
                f"critical (a silent {spec.name} is a protective stop): keep nice = 0, or set "
                f"services.supervisor.config.watch.{spec.name} = \"report\"")


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
    auth = _parse_auth(bus.get("auth"), path)
    tls = parse_tls(bus.get("tls"), path, endpoint)
    access_control = _parse_access_control(bus.get("access_control"), path)
    if allow and auth is None:
        raise ProfileError(f"{path}: bus.allow_non_loopback = true needs [bus.auth] (user/password per service)")
    for side in ("listen", "connect"):  # the Zenoh overrides obey the loopback rule too, checked at load
        endpoints = overrides.get(side, {}).get("endpoints", []) if isinstance(overrides.get(side), dict) else []
        for endpoint in endpoints if isinstance(endpoints, list) else [endpoints]:
            try:
                validate_endpoint(endpoint, allow)
            except ProfileError as exc:
                raise ProfileError(f"{path}: [bus.zenoh.{side}] {exc}") from None
    if access_control is not None and auth is None:
        raise ProfileError(f"{path}: [bus.access_control] names users, so it needs [bus.auth]")
    logins = bus.get("logins", "off")
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
    services = tuple(_as_spec(name, table, path) for name, table in services_table.items())
    _check_niced_services_are_report_only(services, path)
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
        services=services,
        launcher=dict(doc.get("launcher", {})),
        raw=doc,
    )


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
    _deep_merge(conf, profile.zenoh_overrides)
    # Whatever the overrides say, scouting stays off, every endpoint obeys the loopback rule
    # and no message above the bus cap is taken in.
    conf["scouting"]["multicast"]["enabled"] = False
    conf["scouting"]["gossip"]["enabled"] = False
    for side in ("listen", "connect"):
        endpoints = conf.get(side, {}).get("endpoints", [])
        for endpoint in endpoints if isinstance(endpoints, list) else [endpoints]:
            validate_endpoint(endpoint, profile.allow_non_loopback)
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


def _deep_merge(into: dict[str, Any], other: dict[str, Any]) -> None:
    for key, value in other.items():
        if isinstance(value, dict) and isinstance(into.get(key), dict):
            _deep_merge(into[key], value)
        else:
            into[key] = value
