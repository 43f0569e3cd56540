"""`handover-certs`: the TLS certificates of a multi-host bus (issue 17).

Makes, in one folder, a certificate authority for the lab's bus (``ca.pem``, its key
``ca.key`` to keep offline) and, for each host name or address given, a certificate and key
signed by it (``<host>.pem``, ``<host>.key``) whose subject alternative names are that host
(a DNS name or an IP address). The router's host and every client host present their own
certificate (mutual TLS): the router refuses a peer without a certificate of this authority,
and a client refuses a router without one. Keys are written readable by their owner only.

Usage:  handover-certs DIR HOST [HOST ...]      e.g. handover-certs ~/.config/handover/tls 192.168.1.10 kinect-pc
Then, in the profile (docs/security.md):
    [bus.tls]
    ca_file = "~/.config/handover/tls/ca.pem"
    cert_file = "~/.config/handover/tls/192.168.1.10.pem"
    key_file = "~/.config/handover/tls/192.168.1.10.key"
"""

from __future__ import annotations

import argparse
import datetime
import ipaddress
import re
import sys
from pathlib import Path

from services.runtime.errors import ServiceError
from services.runtime.paths import write_new_file

#: How long the certificates are valid, days.
VALID_DAYS = 825


class CertsError(ServiceError):
    """The certificates cannot be made (the message says what to check)."""


class CertsUsageError(CertsError):
    """A host name that cannot be a certificate's name, or files that exist already: exit 2."""

    bad_input = True


#: A DNS name of letters, digits and hyphens (RFC 1123 labels).
_LABEL = r"[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?"
_DNS_NAME = re.compile(rf"^(?=.{{1,253}}$){_LABEL}(\.{_LABEL})*$")


def check_host(host: str) -> None:
    """Raise CertsUsageError unless `host` is an IP address or a DNS name."""
    try:
        ipaddress.ip_address(host)
    except ValueError:
        if not _DNS_NAME.match(host):
            raise CertsUsageError(f"host {host!r} is neither an IP address nor a DNS name (letters, digits, "
                                  "hyphens and dots)") from None


def _name(common_name: str):
    from cryptography import x509
    from cryptography.x509.oid import NameOID

    return x509.Name([x509.NameAttribute(NameOID.ORGANIZATION_NAME, "handover stack"),
                      x509.NameAttribute(NameOID.COMMON_NAME, common_name)])


def _subject_alt_name(host: str):
    from cryptography import x509

    try:
        return x509.IPAddress(ipaddress.ip_address(host))
    except ValueError:
        return x509.DNSName(host)


def make_certificates(directory: Path, hosts: list[str]) -> dict[str, Path]:
    """Write the authority and one certificate per host into `directory`; returns the paths
    by name (``ca``, and each host).

    Raises:
        CertsError: no host, a host name that cannot be a file name, or the folder cannot be written.
    """
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec

    if not hosts:
        raise CertsUsageError("name at least one host (a DNS name or an IP address)")
    for host in hosts:
        check_host(host)
    names = ["ca.key", "ca.pem"] + [f"{h}{suffix}" for h in hosts for suffix in (".key", ".pem")]
    existing = [n for n in names if (directory / n).exists() or (directory / n).is_symlink()]
    if existing:
        raise CertsUsageError(f"{directory} holds {', '.join(existing)} already: a new authority would "
                              "invalidate every host's certificate; choose an empty folder")
    now = datetime.datetime.now(datetime.timezone.utc)
    start, end = now - datetime.timedelta(minutes=5), now + datetime.timedelta(days=VALID_DAYS)
    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca = (x509.CertificateBuilder().subject_name(_name("handover bus CA")).issuer_name(_name("handover bus CA"))
          .public_key(ca_key.public_key()).serial_number(x509.random_serial_number())
          .not_valid_before(start).not_valid_after(end)
          .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
          .add_extension(x509.KeyUsage(digital_signature=True, key_cert_sign=True, crl_sign=True,
                                       content_commitment=False, key_encipherment=False, data_encipherment=False,
                                       key_agreement=False, encipher_only=False, decipher_only=False), critical=True)
          .sign(ca_key, hashes.SHA256()))
    pem = serialization.Encoding.PEM
    key_format = (serialization.PrivateFormat.PKCS8, serialization.NoEncryption())
    try:
        directory.mkdir(parents=True, exist_ok=True)
        paths = {"ca": directory / "ca.pem"}
        write_new_file(directory / "ca.key", ca_key.private_bytes(pem, *key_format), private=True)
        write_new_file(paths["ca"], ca.public_bytes(pem), private=False)
        for host in hosts:
            key = ec.generate_private_key(ec.SECP256R1())
            cert = (x509.CertificateBuilder().subject_name(_name(host)).issuer_name(ca.subject)
                    .public_key(key.public_key()).serial_number(x509.random_serial_number())
                    .not_valid_before(start).not_valid_after(end)
                    .add_extension(x509.SubjectAlternativeName([_subject_alt_name(host)]), critical=False)
                    .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
                    .add_extension(x509.ExtendedKeyUsage([x509.oid.ExtendedKeyUsageOID.SERVER_AUTH,
                                                          x509.oid.ExtendedKeyUsageOID.CLIENT_AUTH]), critical=False)
                    .sign(ca_key, hashes.SHA256()))
            write_new_file(directory / f"{host}.key", key.private_bytes(pem, *key_format), private=True)
            paths[host] = directory / f"{host}.pem"
            write_new_file(paths[host], cert.public_bytes(pem), private=False)
    except OSError as exc:
        raise CertsError(f"cannot write certificates into {directory}: {exc.strerror or exc}") from None
    return paths


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="handover-certs",
        description="Make the TLS certificates of a multi-host bus: an authority (ca.pem, ca.key) and, for each "
                    "host, a certificate and key it signed (HOST.pem, HOST.key). Keys are private to you.")
    parser.add_argument("directory", type=Path, help="where the files go (made if missing)")
    parser.add_argument("hosts", nargs="+", metavar="HOST", help="a host's DNS name or IP address, as the "
                        "profile's endpoint names it")
    args = parser.parse_args(argv)
    try:
        paths = make_certificates(args.directory.expanduser(), args.hosts)
    except CertsError as exc:
        sys.stderr.write(f"handover-certs: error: {exc}\n")
        return 2 if getattr(exc, "bad_input", False) else 1
    lines = [f"authority: {paths.pop('ca')} (keep ca.key offline once every host has its certificate)"]
    lines += [f"{host}: {path} and {path.with_suffix('.key')}" for host, path in paths.items()]
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
