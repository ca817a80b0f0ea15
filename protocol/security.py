"""Optional CURVE authentication of every keepaway port (docs/protocol.md 14 "Security").

ZeroMQ's CURVE mechanism encrypts a connection and authenticates both ends by their public keys; the ZAP
protocol lets the binding process decide which client keys it takes. Without keys every port is plain TCP
and anyone who can reach it can join a team, watch the game or drive the arena: fine on loopback, which
is the default host, and a process that binds anything else without keys says so in one line.

A keys directory (``keepaway keys DIR``, :func:`create_keys`) holds, as pyzmq's certificate files::

    server.key           the arena's public key          every machine (clients check the server with it)
    server.key_secret    the arena's key pair            machines that bind: the server, a coach's arena port
    client.key_secret    a client key pair               machines that connect: players, coach, run, train
    client.key           its public half
    authorized/*.key     the client keys a bound port takes   machines that bind
    clients/NAME/        ``--client NAME``: server.key + NAME's client pair, the whole bundle of one machine

Every process takes ``--keys DIR``. A process that binds (:class:`PortGuard`) makes each port a CURVE
server with the arena's secret key and runs a ZAP authenticator thread on its ZeroMQ context that takes
only the keys in ``DIR/authorized`` (read at start: a change needs a restart) and logs every refusal; a
process that connects (:func:`secure_client`) presents its client pair and expects the arena's public
key. A refused client gets nothing, not even an error: the handshake never completes, so clients that
wait for a first answer say after their timeout what may be wrong (:func:`no_answer`).
"""

from __future__ import annotations

import ipaddress
import logging
import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import click
import zmq
import zmq.auth
from zmq.auth.thread import ThreadAuthenticator

from keepaway.core.log_limit import KIND_ATTR
from keepaway.protocol.endpoints import bind

SERVER_KEY = "server"
CLIENT_KEY = "client"
AUTHORIZED_DIR = "authorized"
CLIENTS_DIR = "clients"
PUBLIC_SUFFIX = ".key"
SECRET_SUFFIX = ".key_secret"
LOOPBACK_NAMES = ("localhost",)
KEYS_ENVVAR = "KEEPAWAY_KEYS"


class SecurityError(ValueError):
    """A keys directory that cannot serve, or a libzmq without CURVE; the message is one line."""


def require_curve() -> None:
    """Raise SecurityError unless this libzmq can do CURVE (built with libsodium or its own tweetnacl)."""
    if not zmq.has("curve"):
        raise SecurityError(f"this libzmq ({zmq.zmq_version()}) has no CURVE support: install a pyzmq wheel "
                            "(bundled libzmq) or a libzmq built with libsodium to use --keys")


def _load(path: Path, secret: bool) -> tuple[bytes, bytes | None]:
    """One certificate file: (public, secret or None); SecurityError naming the file if unreadable."""
    try:
        public, secret_key = zmq.auth.load_certificate(path)
    except (OSError, ValueError) as exc:
        raise SecurityError(f"cannot read the key {path}: {exc}") from None
    if secret and secret_key is None:
        raise SecurityError(f"{path} holds no secret key")
    return public, secret_key


@dataclass(frozen=True)
class KeyDir:
    """A keys directory (module docstring); each role reads only the files it needs, so a client
    machine's directory holds no server secret."""

    path: Path

    @classmethod
    def open(cls, path: Path | str) -> KeyDir:
        """The keys directory at ``path``; SecurityError (one line) if it is not one or CURVE is missing."""
        require_curve()
        directory = Path(path)
        if not directory.is_dir():
            raise SecurityError(f"keys directory {directory} does not exist (create it with keepaway keys DIR)")
        return cls(directory)

    def _file(self, name: str, suffix: str, role: str) -> Path:
        file = self.path / f"{name}{suffix}"
        if not file.is_file():
            raise SecurityError(f"{self.path} has no {file.name}, which {role} needs (keepaway keys DIR)")
        return file

    def server_pair(self) -> tuple[bytes, bytes]:
        """The arena's public and secret key: what a process that binds serves with."""
        public, secret = _load(self._file(SERVER_KEY, SECRET_SUFFIX, "a process that binds ports"), True)
        return public, secret  # type: ignore[return-value]

    def server_public(self) -> bytes:
        """The arena's public key: what a client expects the server to prove it holds."""
        return _load(self._file(SERVER_KEY, PUBLIC_SUFFIX, "a client"), False)[0]

    def client_pair(self) -> tuple[bytes, bytes]:
        """This machine's client public and secret key."""
        public, secret = _load(self._file(CLIENT_KEY, SECRET_SUFFIX, "a client"), True)
        return public, secret  # type: ignore[return-value]

    def authorized(self) -> frozenset[bytes]:
        """The public keys (z85) of ``authorized/*.key``; SecurityError if there are none."""
        folder = self.path / AUTHORIZED_DIR
        keys = frozenset(_load(file, False)[0] for file in sorted(folder.glob(f"*{PUBLIC_SUFFIX}")))
        if not keys:
            raise SecurityError(f"{folder} holds no client key (*{PUBLIC_SUFFIX}): every client would be refused")
        return keys


def open_keys(path: Path | str | None) -> KeyDir | None:
    """``--keys``: None (plain TCP) or the directory, checked (:meth:`KeyDir.open`)."""
    return None if path is None else KeyDir.open(path)


def _check_keys_option(_ctx: click.Context, param: click.Parameter, value: Path | None) -> Path | None:
    if value is None:
        return None
    try:
        return KeyDir.open(value).path.resolve()
    except SecurityError as exc:
        raise click.BadParameter(str(exc), param_hint="--keys") from None


def keys_option(command: Callable[..., None]) -> Callable[..., None]:
    """The ``--keys DIR`` option every process (and ``keepaway run``/``train``, which pass it on) takes: the
    directory's absolute path, or None; a usage error in one line if it is not a keys directory."""
    return click.option("--keys", type=click.Path(file_okay=False, path_type=Path), default=None,
                        envvar=KEYS_ENVVAR, callback=_check_keys_option, metavar="DIR",
                        help=f"Keys directory (keepaway keys): CURVE on every connection, only authorised "
                             f"clients get in [${KEYS_ENVVAR}; default plain TCP].")(command)


def secure_client(socket: zmq.Socket, keys: KeyDir | None) -> None:
    """Before ``connect``: present this machine's client pair and expect the arena's public key (nothing
    without keys)."""
    if keys is None:
        return
    socket.curve_serverkey = keys.server_public()
    socket.curve_publickey, socket.curve_secretkey = keys.client_pair()


def is_loopback(host: str) -> bool:
    """``host`` reaches only this machine (127.0.0.0/8, ::1, localhost); ``*`` and names do not count."""
    if host in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def exposure_warning(host: str) -> str:
    """The one line a process prints when it binds ``host`` without keys and ``host`` is not loopback."""
    return (f"listening on {host} without --keys: anyone who can reach this port can join, watch or drive the "
            f"arena; use --keys DIR (keepaway keys) or bind 127.0.0.1")


def no_answer(endpoint: str, seconds: float) -> str:
    """What a client says when its first answer does not come: a refused CURVE handshake is silent."""
    return (f"no answer from the server at {endpoint} within {seconds:g} s: is it running, and do you have an "
            f"authorised key (--keys)?")


class _KeyCheck:
    """The ZAP credentials provider: takes the authorised keys, logs each refusal with the peer's address
    (set by :class:`_Authenticator` before each request). The refusals of one address are one kind of line
    for a rate-limited log (``core.log_limit``), whatever key each presents: a client trying ever new keys
    costs one line a second."""

    def __init__(self, allowed: frozenset[bytes], folder: Path, log: logging.Logger) -> None:
        self.allowed = allowed
        self.folder = folder
        self.log = log
        self.address = "?"

    def callback(self, _domain: str, key: bytes) -> bool:
        if key in self.allowed:
            return True
        self.log.warning("refused a CURVE handshake from %s: key %s is not in %s", self.address,
                         key.decode("ascii", "replace"), self.folder,
                         extra={KIND_ATTR: ("curve_refused", self.address)})
        return False


class _Authenticator(ThreadAuthenticator):
    """pyzmq's ZAP thread, telling the key check which address each request comes from."""

    key_check: _KeyCheck

    async def handle_zap_message(self, msg: list[bytes]) -> None:
        self.key_check.address = msg[3].decode("utf-8", "replace") if len(msg) > 3 else "?"
        await super().handle_zap_message(msg)


class PortGuard:
    """Binds the ports of one process (one ZeroMQ context): with keys, each a CURVE server behind a ZAP
    authenticator taking only ``DIR/authorized``; without, plain TCP, and one warning (on ``log``) for a host
    that is not loopback. Close it before terminating the context (the ZAP thread holds a socket)."""

    def __init__(self, ctx: zmq.Context, keys: KeyDir | None, log: logging.Logger) -> None:
        self.ctx = ctx
        self.keys = keys
        self.log = log
        self.auth: _Authenticator | None = None
        self._warned: set[str] = set()
        if keys is not None:
            self._pair = keys.server_pair()
            check = _KeyCheck(keys.authorized(), keys.path / AUTHORIZED_DIR, log)
            self.auth = _Authenticator(ctx, log=logging.getLogger("zmq.auth"))
            self.auth.key_check = check
            self.auth.start()
            self.auth.configure_curve_callback(domain="*", credentials_provider=check)

    def bind(self, socket: zmq.Socket, host: str, port: int) -> int:
        """``protocol.endpoints.bind`` behind the guard; returns the port bound."""
        if self.keys is not None:
            socket.curve_server = True
            socket.curve_publickey, socket.curve_secretkey = self._pair
        elif not is_loopback(host) and host not in self._warned:
            self._warned.add(host)
            self.log.warning(exposure_warning(host))
        return bind(socket, host, port)

    def close(self) -> None:
        if self.auth is not None:
            self.auth.stop()
            self.auth = None


def _write_pair(directory: Path, name: str) -> Path:
    """A new key pair as ``directory/name.key`` and ``name.key_secret`` (the secret readable by its owner
    only); returns the public file."""
    directory.mkdir(parents=True, exist_ok=True)
    public, secret = zmq.auth.create_certificates(directory, name)
    Path(secret).chmod(0o600)
    return Path(public)


def create_keys(directory: Path, clients: Sequence[str] = ()) -> list[str]:
    """``keepaway keys``: the server pair, the default client pair and one bundle per named client in
    ``directory``, each authorised; existing pairs are kept (adding a client later does not change the
    others). Returns one line per file or folder made or kept, saying which machine it goes to."""
    require_curve()
    for name in clients:
        if not name or not name.replace("-", "").replace("_", "").isalnum():
            raise SecurityError(f"client name {name!r}: use letters, digits, - and _")
    lines = []
    authorized = directory / AUTHORIZED_DIR
    server_public = directory / f"{SERVER_KEY}{PUBLIC_SUFFIX}"
    for name, where in ((SERVER_KEY, "machines that bind (server, coach --arena-port); server.key: every machine"),
                        (CLIENT_KEY, "machines that connect (players, coach, keepaway run/train)")):
        if (directory / f"{name}{SECRET_SUFFIX}").is_file():
            lines.append(f"kept    {directory / name}.key(_secret)")
            continue
        public = _write_pair(directory, name)
        if name == CLIENT_KEY:
            authorized.mkdir(exist_ok=True)
            shutil.copy(public, authorized / public.name)
        lines.append(f"created {directory / name}.key(_secret): {where}")
    for name in clients:
        bundle = directory / CLIENTS_DIR / name
        if (bundle / f"{CLIENT_KEY}{SECRET_SUFFIX}").is_file():
            lines.append(f"kept    {bundle}")
            continue
        public = _write_pair(bundle, CLIENT_KEY)
        shutil.copy(server_public, bundle / server_public.name)
        authorized.mkdir(exist_ok=True)
        shutil.copy(public, authorized / f"{name}{PUBLIC_SUFFIX}")
        lines.append(f"created {bundle}: the keys directory of machine {name} (copy it there, give it to --keys)")
    lines.append(f"authorised client keys: {authorized} (delete one and restart the arena to revoke it)")
    return lines


@click.command("keys")
@click.argument("directory", type=click.Path(file_okay=False, path_type=Path))
@click.option("--client", "clients", multiple=True, metavar="NAME",
              help="Also a key pair for machine NAME, bundled as DIRECTORY/clients/NAME (repeatable).")
def keys_command(directory: Path, clients: tuple[str, ...]) -> None:
    """Create CURVE keys for --keys: the arena's server pair, a client pair and, per --client, a
    machine's bundle; all clients authorised. Existing pairs are kept.

    Copy DIRECTORY whole to machines that run the server or a coach with --arena-port (it holds the
    server's secret key), and only DIRECTORY/clients/NAME to machine NAME.
    """
    try:
        lines = create_keys(directory, clients)
    except (SecurityError, OSError) as exc:
        raise click.ClickException(str(exc)) from None
    for line in lines:
        click.echo(line)


__all__ = ["AUTHORIZED_DIR", "KEYS_ENVVAR", "KeyDir", "PortGuard", "SecurityError", "create_keys", "exposure_warning",
           "is_loopback", "keys_command", "keys_option", "no_answer", "open_keys", "require_curve", "secure_client"]
