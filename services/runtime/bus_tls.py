"""TLS on the bus (``[bus.tls]`` of a multi-host profile, issue 17).

Every session presents this host's certificate and trusts only the lab's authority (mutual
TLS): the router refuses a peer without a certificate signed by ``ca_file``, and a client a
router without one. The endpoint must then be ``tls/<host>:<port>``: a plain-TCP peer finds
nothing to talk to. ``handover-certs`` makes the files (`services.launcher.certs`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from services.runtime.errors import ProfileError

_KEYS = ("ca_file", "cert_file", "key_file")
#: A host's own certificate and key, when the profile is shared by several hosts: these
#: variables override ``cert_file`` and ``key_file`` (as ``HANDOVER_BUS_CREDENTIALS`` does
#: the logins).
CERT_ENV, KEY_ENV = "HANDOVER_BUS_TLS_CERT", "HANDOVER_BUS_TLS_KEY"


@dataclass(frozen=True)
class BusTls:
    """This host's TLS files (PEM).

    Attributes:
        ca_file: the lab's certificate authority.
        cert_file: this host's certificate, signed by it.
        key_file: its private key (readable by its owner only).
    """

    ca_file: Path
    cert_file: Path
    key_file: Path

    def checked(self) -> BusTls:
        """The files in use (this host's certificate and key from `CERT_ENV`/`KEY_ENV` when
        set), once every one exists and the key is private.

        Raises:
            ProfileError: a file is missing, or the key is readable by others.
        """
        if bool(os.environ.get(CERT_ENV)) != bool(os.environ.get(KEY_ENV)):
            raise ProfileError(f"set both {CERT_ENV} and {KEY_ENV} (this host's certificate and its key), or neither")
        self = replace(self, cert_file=Path(os.environ.get(CERT_ENV) or self.cert_file).expanduser(),
                       key_file=Path(os.environ.get(KEY_ENV) or self.key_file).expanduser())
        for name in _KEYS:
            path = getattr(self, name)
            if not path.is_file():
                raise ProfileError(f"bus TLS {name} {path} not found (make them with handover-certs)")
        if self.key_file.stat().st_mode & 0o077:
            raise ProfileError(f"bus TLS key_file {self.key_file} is readable by others: chmod 600 {self.key_file}")
        return self

    def zenoh_dict(self) -> dict[str, Any]:
        """The ``transport.link.tls`` section of a session's Zenoh config (router and client)."""
        tls = self.checked()
        return {
            "root_ca_certificate": str(tls.ca_file),
            "listen_certificate": str(tls.cert_file),
            "listen_private_key": str(tls.key_file),
            "connect_certificate": str(tls.cert_file),
            "connect_private_key": str(tls.key_file),
            "enable_mtls": True,
        }


def parse_tls(table: Any, path: Path, endpoint: str) -> BusTls | None:
    """`[bus.tls]` of the profile at `path` (None when absent).

    Raises:
        ProfileError: keys missing or unknown, or the endpoint is not ``tls/``.
    """
    if table is None:
        if endpoint.startswith("tls/"):
            raise ProfileError(f"{path}: a tls/ endpoint needs [bus.tls] (ca_file, cert_file, key_file)")
        return None
    if not isinstance(table, dict) or set(table) != set(_KEYS):
        raise ProfileError(f"{path}: [bus.tls] must hold exactly ca_file, cert_file and key_file")
    files = {}
    for name in _KEYS:
        value = table[name]
        if not isinstance(value, str) or not value:
            raise ProfileError(f"{path}: bus.tls.{name} must be a path")
        resolved = Path(value).expanduser()
        files[name] = resolved if resolved.is_absolute() else path.parent / resolved
    if not endpoint.startswith("tls/"):
        raise ProfileError(f"{path}: with [bus.tls] the endpoint must be tls/<host>:<port>, not {endpoint!r}")
    return BusTls(**files)
