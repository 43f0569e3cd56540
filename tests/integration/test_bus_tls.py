"""Mutual TLS on the bus (issue 17, `[bus.tls]`): certificates made at test time with
`handover-certs`' own code, a real router process on a `tls/127.0.0.1` endpoint. A client with
the lab's certificate talks; a plain-TCP peer, a client with another authority's certificate
and a client that trusts the router but shows a foreign certificate are all refused."""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import pytest

from services.launcher.certs import main as certs_main, make_certificates
from services.launcher.processes import RouterProcess
from services.runtime.bus_tls import BusTls
from services.runtime.errors import BusError, ProfileError
from services.runtime.node import open_session
from services.runtime.profile import free_tcp_port, load_profile_file
from services.runtime.zenoh_config import zenoh_config_dict
from services.runtime.testing import wait_until

HOST = "127.0.0.1"


def _profile(tmp: Path, port: int, tls_dir: Path) -> Path:
    creds = tmp / "creds"
    creds.write_text("alice:a\nbob:b\n")
    creds.chmod(0o600)
    path = tmp / "tls.toml"
    path.write_text(f'[bus]\nendpoint = "tls/{HOST}:{port}"\nprefix = "handover/v1"\nallow_non_loopback = true\n'
                    f'[bus.auth]\ncredentials_file = "{creds}"\n'
                    '[bus.access_control]\n[bus.access_control.users.alice]\npublish = ["{prefix}/test/**"]\n'
                    '[bus.access_control.users.bob]\nsubscribe = ["{prefix}/test/**"]\n'
                    f'[bus.tls]\nca_file = "{tls_dir}/ca.pem"\ncert_file = "{tls_dir}/{HOST}.pem"\n'
                    f'key_file = "{tls_dir}/{HOST}.key"\n')
    return path


@pytest.fixture
def tls_bus(tmp_path):
    make_certificates(tmp_path / "lab", [HOST])
    make_certificates(tmp_path / "other", [HOST])
    profile = load_profile_file(_profile(tmp_path, free_tcp_port(), tmp_path / "lab"))
    router = RouterProcess(json.dumps(zenoh_config_dict(profile, "router")))
    router.start()
    try:
        yield profile, tmp_path
    finally:
        router.stop()


def test_the_labs_certificate_talks_and_nothing_else_connects(tls_bus):
    profile, tmp = tls_bus
    alice, bob = (open_session(profile, "client", timeout_s=10.0, user=u) for u in ("alice", "bob"))
    got: list[bytes] = []
    try:
        bob.declare_subscriber("handover/v1/test/tls", lambda s: got.append(s.payload.to_bytes()))
        time.sleep(0.3)
        alice.put("handover/v1/test/tls", b"over tls")
        assert wait_until(lambda: b"over tls" in got, 5.0), got
    finally:
        alice.close()
        bob.close()
    other = tmp / "other"
    refused = {
        "plain TCP": dataclasses.replace(profile, endpoint=profile.endpoint.replace("tls/", "tcp/"), tls=None),
        "another authority": dataclasses.replace(profile, tls=BusTls(other / "ca.pem", other / f"{HOST}.pem",
                                                                     other / f"{HOST}.key")),
        "a foreign client certificate": dataclasses.replace(profile, tls=BusTls(
            profile.tls.ca_file, other / f"{HOST}.pem", other / f"{HOST}.key")),
    }
    for what, stranger in refused.items():
        with pytest.raises(BusError):
            open_session(stranger, "client", timeout_s=2.0, user="alice")
            pytest.fail(f"{what}: connected")


def test_a_tls_profile_is_checked_when_it_loads(tmp_path):
    make_certificates(tmp_path / "lab", [HOST])
    path = _profile(tmp_path, 7447, tmp_path / "lab")
    text = path.read_text()
    path.write_text(text.replace("tls/", "tcp/"))
    with pytest.raises(ProfileError, match="the endpoint must be tls/"):
        load_profile_file(path)
    path.write_text(text.replace('key_file = "', 'key = "'))
    with pytest.raises(ProfileError, match=r"\[bus.tls\] must hold exactly"):
        load_profile_file(path)
    path.write_text(text)
    router = zenoh_config_dict(load_profile_file(path), "router")
    assert router["listen"]["endpoints"] == [f"tls/{HOST}:7447"] and router["transport"]["link"]["tls"]["enable_mtls"]
    with pytest.raises(ProfileError, match="TLS only"):  # no plain-TCP listener beside the TLS one
        zenoh_config_dict(dataclasses.replace(load_profile_file(path), zenoh_overrides={
            "listen": {"endpoints": [f"tls/{HOST}:7447", f"tcp/{HOST}:7448"]}}), "router")
    with pytest.raises(ProfileError, match="TLS only"):  # a CLI override cannot turn TLS off
        load_profile_file(path).with_bus(endpoint="tcp/127.0.0.1:7447")
    assert load_profile_file(path).with_bus(endpoint="tls/127.0.0.1:7448").endpoint == "tls/127.0.0.1:7448"
    (tmp_path / "lab" / f"{HOST}.key").chmod(0o644)
    with pytest.raises(ProfileError, match="readable by others"):
        zenoh_config_dict(load_profile_file(path), "client", user="alice")


def test_handover_certs_writes_private_keys_and_says_where(tmp_path, capsys):
    assert certs_main([str(tmp_path / "tls"), "192.168.1.10", "kinect-pc"]) == 0
    out = capsys.readouterr().out
    assert "192.168.1.10:" in out and "kinect-pc:" in out
    for name in ("ca.key", "192.168.1.10.key", "kinect-pc.key"):
        assert (tmp_path / "tls" / name).stat().st_mode & 0o077 == 0
    from cryptography import x509

    cert = x509.load_pem_x509_certificate((tmp_path / "tls" / "kinect-pc.pem").read_bytes())
    names = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert names.get_values_for_type(x509.DNSName) == ["kinect-pc"]
    ca = x509.load_pem_x509_certificate((tmp_path / "tls" / "ca.pem").read_bytes())
    cert.verify_directly_issued_by(ca)


@pytest.mark.parametrize("hosts", [["häst"], ["a b"], ["../x"], ["x-"]])
def test_handover_certs_refuses_a_bad_host_before_writing_anything(tmp_path, capsys, hosts):
    assert certs_main([str(tmp_path / "tls"), "good-host", *hosts]) == 2
    assert "neither an IP address nor a DNS name" in capsys.readouterr().err
    assert not (tmp_path / "tls").exists() or not any((tmp_path / "tls").iterdir())


def test_handover_certs_never_overwrites_an_authority(tmp_path, capsys):
    assert certs_main([str(tmp_path / "tls"), "robot-pc"]) == 0
    ca = (tmp_path / "tls" / "ca.pem").read_bytes()
    assert certs_main([str(tmp_path / "tls"), "kinect-pc"]) == 2
    assert "holds ca.key, ca.pem already" in capsys.readouterr().err
    assert (tmp_path / "tls" / "ca.pem").read_bytes() == ca and not (tmp_path / "tls" / "kinect-pc.pem").exists()
