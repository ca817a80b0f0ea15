"""The keys module (protocol/security.py): ``keepaway keys``' files, what each role reads, the loopback rule,
and CURVE between real ZeroMQ sockets: an authorised client gets through, an unknown key and a client
without keys get nothing, and each refused key is logged with the peer's address."""

from __future__ import annotations

import logging
import stat
import time

import pytest
import zmq
from click.testing import CliRunner

from keepaway.cli import main
from keepaway.protocol.security import (
    KeyDir,
    PortGuard,
    SecurityError,
    create_keys,
    exposure_warning,
    is_loopback,
    secure_client,
)

WAIT_MS = 1500  # a CURVE handshake on loopback takes milliseconds


@pytest.fixture
def keys(tmp_path):
    create_keys(tmp_path / "keys", ["laptop"])
    return KeyDir.open(tmp_path / "keys")


def names(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def test_keys_writes_the_server_pair_a_client_pair_and_one_bundle_per_named_client(tmp_path):
    result = CliRunner().invoke(main, ["keys", str(tmp_path / "k"), "--client", "laptop"])
    assert result.exit_code == 0, result.output
    assert names(tmp_path / "k") == [
        "authorized/client.key", "authorized/laptop.key", "client.key", "client.key_secret",
        "clients/laptop/client.key", "clients/laptop/client.key_secret", "clients/laptop/server.key",
        "server.key", "server.key_secret"]
    for secret in (tmp_path / "k").rglob("*.key_secret"):
        assert stat.S_IMODE(secret.stat().st_mode) == 0o600, secret
    assert (tmp_path / "k/clients/laptop/server.key").read_bytes() == (tmp_path / "k/server.key").read_bytes()
    assert "copy it there" in result.output


def test_keys_run_again_keeps_every_pair_and_adds_a_new_client(tmp_path):
    create_keys(tmp_path / "k", ["laptop"])
    before = {name: (tmp_path / "k" / name).read_bytes() for name in names(tmp_path / "k")}
    lines = create_keys(tmp_path / "k", ["laptop", "desk"])
    assert {name: (tmp_path / "k" / name).read_bytes() for name in before} == before
    assert (tmp_path / "k/authorized/desk.key").is_file()
    assert sum(line.startswith("kept") for line in lines) == 3


def test_a_bad_client_name_is_refused_in_one_line_before_anything_is_written(tmp_path):
    result = CliRunner().invoke(main, ["keys", str(tmp_path / "k"), "--client", "../x"])
    assert result.exit_code == 1
    assert result.output == "Error: client name '../x': use letters, digits, - and _\n"
    assert not (tmp_path / "k").exists()


def test_each_role_reads_only_its_files(keys):
    bundle = KeyDir.open(keys.path / "clients/laptop")
    assert bundle.server_public() == keys.server_public() == keys.server_pair()[0]
    assert bundle.client_pair()[0] != keys.client_pair()[0]
    with pytest.raises(SecurityError, match=r"has no server.key_secret, which a process that binds ports needs"):
        bundle.server_pair()
    assert len(keys.authorized()) == 2


def test_a_directory_that_cannot_serve_is_one_line(tmp_path, keys):
    with pytest.raises(SecurityError, match="does not exist"):
        KeyDir.open(tmp_path / "nowhere")
    for file in (keys.path / "authorized").iterdir():
        file.unlink()
    with pytest.raises(SecurityError, match="holds no client key"):
        keys.authorized()
    (keys.path / "client.key_secret").write_text("not a certificate")
    with pytest.raises(SecurityError, match="cannot read the key .*client.key_secret"):
        keys.client_pair()


@pytest.mark.parametrize("host, loopback", [
    ("127.0.0.1", True), ("127.4.5.6", True), ("::1", True), ("[::1]", True), ("localhost", True),
    ("0.0.0.0", False), ("*", False), ("::", False), ("10.0.0.5", False), ("arena.example.org", False)])
def test_only_loopback_hosts_are_safe_without_keys(host, loopback):
    assert is_loopback(host) is loopback


@pytest.fixture
def ctx():
    context = zmq.Context()
    yield context
    context.destroy(linger=0)


def dealer(ctx, server_public=None, client_pair=None):
    sock = ctx.socket(zmq.DEALER)
    sock.linger = 0
    if server_public is not None:
        sock.curve_serverkey = server_public
        sock.curve_publickey, sock.curve_secretkey = client_pair
    return sock


def test_a_guarded_port_takes_authorised_keys_only_and_logs_each_refusal(ctx, keys, tmp_path, caplog):
    log = logging.getLogger("test.security.guard")
    guard = PortGuard(ctx, keys, log)
    router = ctx.socket(zmq.ROUTER)
    router.linger = 0
    try:
        endpoint = f"tcp://127.0.0.1:{guard.bind(router, '127.0.0.1', 0)}"
        create_keys(tmp_path / "strangers")
        stranger = KeyDir.open(tmp_path / "strangers")
        clients = {"main": dealer(ctx), "laptop": dealer(ctx), "stranger": dealer(ctx), "plain": dealer(ctx)}
        secure_client(clients["main"], keys)
        secure_client(clients["laptop"], KeyDir.open(keys.path / "clients/laptop"))
        clients["stranger"] = dealer(ctx, keys.server_public(), stranger.client_pair())
        with caplog.at_level(logging.WARNING, logger=log.name):
            for name, sock in clients.items():
                sock.connect(endpoint)
                sock.send(name.encode())
            got = set()
            deadline = time.monotonic() + WAIT_MS / 1000
            while time.monotonic() < deadline:
                if router.poll(50):
                    ident, data = router.recv_multipart()
                    got.add(data.decode())
                    router.send_multipart([ident, b"ok"])
        assert got == {"main", "laptop"}
        assert clients["main"].poll(WAIT_MS) and clients["main"].recv() == b"ok"
        refusals = [r.getMessage() for r in caplog.records if r.name == log.name]
        assert refusals == [f"refused a CURVE handshake from 127.0.0.1: key {stranger.client_pair()[0].decode()} "
                            f"is not in {keys.path / 'authorized'}"]
    finally:
        router.close()
        guard.close()


def test_a_client_expecting_another_server_key_gets_nothing(ctx, keys, tmp_path):
    guard = PortGuard(ctx, keys, logging.getLogger("test.security.other"))
    router = ctx.socket(zmq.ROUTER)
    router.linger = 0
    try:
        port = guard.bind(router, "127.0.0.1", 0)
        create_keys(tmp_path / "other")
        other = KeyDir.open(tmp_path / "other")
        sock = dealer(ctx, other.server_public(), keys.client_pair())  # an authorised key, the wrong server
        sock.connect(f"tcp://127.0.0.1:{port}")
        sock.send(b"hello")
        assert not router.poll(WAIT_MS)
    finally:
        router.close()
        guard.close()


def test_binding_beyond_loopback_without_keys_warns_once_per_host(ctx, caplog):
    log = logging.getLogger("test.security.exposed")
    guard = PortGuard(ctx, None, log)
    socks = [ctx.socket(zmq.ROUTER) for _ in range(3)]
    try:
        with caplog.at_level(logging.WARNING, logger=log.name):
            guard.bind(socks[0], "127.0.0.1", 0)
            guard.bind(socks[1], "0.0.0.0", 0)
            guard.bind(socks[2], "0.0.0.0", 0)
    finally:
        for sock in socks:
            sock.close(linger=0)
        guard.close()
    assert [r.getMessage() for r in caplog.records if r.name == log.name] == [exposure_warning("0.0.0.0")]


def test_refusals_from_one_address_are_one_kind_of_line_whatever_the_key(tmp_path, caplog):
    # A client trying ever new keys from one address costs one line a second in a rate-limited log.
    from keepaway.core.log_limit import RepeatLimit
    from keepaway.protocol.security import _KeyCheck

    log = logging.getLogger("test.security.refusals")
    limit = RepeatLimit(clock=lambda: 0.0)
    log.addFilter(limit)
    check = _KeyCheck(frozenset(), tmp_path, log)
    try:
        with caplog.at_level(logging.WARNING, logger=log.name):
            check.address = "127.0.0.1"
            assert not any(check.callback("*", f"key{i}".encode()) for i in range(50))
            check.address = "10.0.0.9"
            check.callback("*", b"other")
        lines = [r.getMessage() for r in caplog.records if r.name == log.name]
        assert [line.split(":")[0] for line in lines] == ["refused a CURVE handshake from 127.0.0.1",
                                                          "refused a CURVE handshake from 10.0.0.9"]
    finally:
        log.removeFilter(limit)
