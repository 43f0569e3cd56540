"""Who may use the bus: user/password logins (``[bus.auth]``) and the router's access control
list (``[bus.access_control]``), as a profile declares them (`services.runtime.profile`).

The per-run logins of a default run are built from the same classes by the launcher
(`services.launcher.logins`); the Zenoh config sections come out of `zenoh_dict` and
`BusAuth` (`services.runtime.zenoh_config`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bus_schema.topics import HEARTBEAT, sender_name_ok
from services.runtime.errors import ProfileError

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
        env_override: whether ``HANDOVER_BUS_CREDENTIALS`` may replace it (not for the
            dictionary `handover-up` makes for its own run).
    """

    credentials_file: Path
    env_override: bool = True

    def checked_file(self) -> Path:
        """The credentials file in use (env override first), checked to exist and be private.

        Raises:
            ProfileError: missing, or readable by group/others.
        """
        import os

        from_env = os.environ.get(CREDENTIALS_ENV) if self.env_override else None
        path = Path(from_env or self.credentials_file).expanduser()
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


def parse_auth(table: Any, path: Path) -> BusAuth | None:
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


def parse_access_control(table: Any, path: Path) -> AccessControl | None:
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
        if not sender_name_ok(name):  # a user's name is one key chunk (its heartbeat and liveliness keys)
            raise ProfileError(f"{path}: bus.access_control user {name!r} must not hold / * $ ? #")
        if not isinstance(perms, dict) or set(perms) - {"publish", "subscribe", "query"}:
            raise ProfileError(f"{path}: [bus.access_control.users.{name}] may hold publish, subscribe, query")
        users[name] = UserPermissions(
            **{k: _key_list(v, f"bus.access_control.users.{name}.{k}", path) for k, v in perms.items()})
    common = _key_list(table.get("common_publish", []),
                       "bus.access_control.common_publish", path)
    return AccessControl(default, users, common)
