"""The rcssserver-protocol front: rcssserver's UDP text clients seated at our server (docs/protocol.md §16).

The socket edge of :class:`rcss.seat.TextSeat`. It binds one UDP port, where clients send their
``(init ...)`` or ``(reconnect ...)`` as they would to rcssserver; for each client it opens, as rcssserver
does from protocol version 8 on, a UDP socket of the client's own (the client then talks to the port the
replies come from), and a link to our server, so that to our server each text client is one more player:
in the server's process (``keepaway server --rcss-port``) a direct call with no socket between them, its
UDP sockets watched by the server's own poller; as a process of its own (``keepaway rcss-front``) a ZeroMQ
DEALER to the server's players port. The server stays the one authority: the front only translates, so a
game is the same game whichever protocol its players speak.

Bad input never stops the front or the game: a malformed or unknown command gets rcssserver's error text
back, a datagram beyond rcssserver's receive buffer is cut to it as rcssserver cuts it, a client that
floods its port has at most :data:`READS_PER_ROUND` datagrams read per poll round (the rest waits, and
beyond the socket's buffer is lost, that client's loss), and at most ``max_clients`` clients are seated.
"""

from __future__ import annotations

import errno
import logging
import socket
from collections.abc import Callable
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, Protocol

import msgpack
import zmq

from keepaway.core.log_limit import KIND_ATTR, RepeatLimit
from keepaway.protocol import messages as m
from keepaway.protocol.codec import Message, encode
from keepaway.protocol.endpoints import configure
from keepaway.protocol.errors import ProtocolError
from keepaway.protocol.messages import MAX_PLAYERS, decode_for_player
from keepaway.protocol.security import KeyDir, secure_client
from keepaway.rcss import render, see_text
from keepaway.rcss.commands import (
    MAX_DATAGRAM_BYTES,
    NO_MORE_PLAYER,
    NO_MORE_TEAM,
    ONLY_INIT_ON_INIT_PORT,
    ConnectRefused,
    ReconnectRequest,
    parse_connect,
)
from keepaway.rcss.seat import TeamNames, TextSeat

log = logging.getLogger("keepaway.rcss")
repeat_limit = RepeatLimit()  # a line of one kind at most once a second (core/log_limit.py)
log.addFilter(repeat_limit)

READS_PER_ROUND = 32  # datagrams read from one socket per poll round
POLL_MS = 100  # the longest wait between checks of the stop flag
TEXT_ENCODING = "latin-1"  # every byte is a character: the grammar, not the decoder, refuses bad ones


@dataclass(frozen=True)
class FrontConfig:
    """Where the front listens and which server it seats its clients at."""

    host: str = "127.0.0.1"
    port: int = 6000  # rcssserver's player port; 0: any free one
    server: str = ""  # a front of its own: our server's players endpoint, e.g. tcp://127.0.0.1:6000
    keys: KeyDir | None = None  # a front of its own: CURVE keys towards our server (docs/protocol.md §15)
    max_clients: int = MAX_PLAYERS


class ServerLink(Protocol):
    """One text client's way to our server: our protocol's frames out (:meth:`send`); the server's frames
    come back through the ``deliver`` callable the link was made with."""

    def send(self, data: bytes) -> None: ...

    def close(self) -> None: ...


# Makes a client's link: given the front and the callable that takes each of the server's frames for it.
LinkMaker = Callable[["Front", Callable[[bytes], None]], ServerLink]


class DealerLink:
    """A link over ZeroMQ: a DEALER to our server's players port, read by the front's poller (the front
    as a process of its own, ``keepaway rcss-front``)."""

    def __init__(self, front: Front, deliver: Callable[[bytes], None]) -> None:
        self.front = front
        self.deliver = deliver
        self.dealer = dealer = front.ctx.socket(zmq.DEALER)
        configure(dealer)
        secure_client(dealer, front.config.keys)
        dealer.connect(front.config.server)
        front.watch(dealer, self._read)

    def _read(self) -> None:
        for _ in range(READS_PER_ROUND * 4):
            try:
                data = self.dealer.recv(zmq.NOBLOCK)
            except zmq.Again:
                return
            self.deliver(data)

    def send(self, data: bytes) -> None:
        try:
            self.dealer.send(data, zmq.NOBLOCK)
        except zmq.Again:
            log.warning("our server is not reachable; a message is lost", extra={KIND_ATTR: ("unreachable",)})

    def close(self) -> None:
        self.front.unwatch(self.dealer)
        self.dealer.close(linger=0)


class _Client:
    """A text client: its address, its own UDP socket, its link to our server and its seat."""

    def __init__(self, addr: tuple[str, int], seat: TextSeat, udp: socket.socket) -> None:
        self.addr = addr
        self.seat = seat
        self.udp = udp
        self.link: ServerLink | None = None


class Front:
    """Text clients seated at our server. The front watches its sockets in a poller, its own
    (:meth:`run`, a front of its own) or the server's (``keepaway server --rcss-port``: the server's loop
    hands each ready socket to :meth:`on_event`, and the links call into the server without a socket
    between them)."""

    def __init__(self, config: FrontConfig, poller: zmq.Poller | None = None, link: LinkMaker = DealerLink) -> None:
        self.config = config
        self.link = link
        self.ctx = zmq.Context() if link is DealerLink else None
        self.names = TeamNames()
        self.versions: dict[tuple[str, int], float] = {}  # (our team, unum) -> the version it was seated with
        self.clients: dict[tuple[str, int], _Client] = {}  # by the client's address
        self.poller = poller if poller is not None else zmq.Poller()
        self.readers: dict[Any, tuple[_Client | None, Callable[[], None]]] = {}  # poll key -> its reader
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.setblocking(False)
        self.port = 0
        self.outgoing: list[tuple[socket.socket, bytes, tuple[str, int]]] = []  # datagrams until flush()

    def bind(self) -> int:
        """Bind the init port; return it (the OS's pick for port 0)."""
        self.udp.bind((self.config.host, self.config.port))
        self.port = self.udp.getsockname()[1]
        see_text.compile_kernel()
        self.watch(self.udp.fileno(), self._on_init_port, None)
        versions = render.SUPPORTED_VERSIONS
        log.info("rcssserver protocol on udp://%s:%d (versions %d-%d)", self.config.host, self.port,
                 versions.start, versions.stop - 1)
        return self.port

    def watch(self, key: Any, reader: Callable[[], None], client: _Client | None = None) -> None:
        """Poll ``key`` (a socket's file number or a ZeroMQ socket); call ``reader`` when it is ready."""
        self.readers[key] = (client, reader)
        self.poller.register(key, zmq.POLLIN)

    def unwatch(self, key: Any) -> None:
        if self.readers.pop(key, None) is not None:
            self.poller.unregister(key)

    def run(self, stopped: Callable[[], bool]) -> None:
        """Serve with the front's own poller until ``stopped()`` is true."""
        while not stopped():
            self.flush()
            for key, _ in self.poller.poll(POLL_MS):
                self.on_event(key)

    def on_event(self, key: Any) -> bool:
        """Serve one ready socket; False if it is not the front's. A fault in serving one client (a bug,
        not bad input: that is answered) is logged with its traceback and costs that client its seat,
        never the others'."""
        entry = self.readers.get(key)
        if entry is None:
            return False
        client, reader = entry
        self._guarded(client, reader)
        return True

    def _guarded(self, client: _Client | None, work: Callable[..., None], *args: Any) -> None:
        """``work(*args)``; a fault in it is logged and costs ``client`` (if any) its seat."""
        try:
            work(*args)
        except Exception:
            if client is None:
                log.exception("the front failed at a socket of its own")
            else:
                log.exception("%s: dropped after a fault of the front", client.seat.describe())
                self._drop(client)

    def close(self) -> None:
        self.flush()
        for client in list(self.clients.values()):
            self._drop(client)
        self.unwatch(self.udp.fileno())
        self.udp.close()
        if self.ctx is not None:
            self.ctx.term()
        repeat_limit.flush()

    # -- the init port -----------------------------------------------------------------------------------
    def _on_init_port(self) -> None:
        for data, addr in _datagrams(self.udp):
            if addr in self.clients:  # rcssserver: a seated client of version 8+ talks to its own port
                replies: tuple[str, ...] = (ONLY_INIT_ON_INIT_PORT,)
            else:
                try:
                    replies = self._join(addr, data)
                except Exception:  # a fault of the front, not bad input: that is answered
                    log.exception("the front failed to seat a client at %s:%d", *addr)
                    continue
            for reply in replies:
                self._send_to(self.udp, addr, reply)

    def _join(self, addr: tuple[str, int], data: bytes) -> tuple[str, ...]:
        """Seat a new client from its first datagram; rcssserver's refusal if it cannot be."""
        try:
            request = parse_connect(data)
        except ConnectRefused as exc:
            return exc.replies
        if not isinstance(request, ReconnectRequest) and not render.supported(request.version):
            return (NO_MORE_PLAYER,)
        if len(self.clients) >= self.config.max_clients:
            return (NO_MORE_PLAYER,)
        team = self.names.join(request.team)
        if team is None:
            return (NO_MORE_TEAM,)
        if isinstance(request, ReconnectRequest):
            version = self.versions.get((team, request.unum), float(render.SUPPORTED_VERSIONS.stop - 1))
        else:
            version = request.version
        seat = TextSeat(request, team, self.names, version)
        udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        udp.setblocking(False)
        udp.bind((self.config.host, 0))
        client = _Client(addr, seat, udp)
        self.clients[addr] = client
        self.watch(udp.fileno(), lambda: self._on_client(client), client)
        client.link = self.link(self, lambda data: self._guarded(client, self._on_server, client, data))
        client.link.send(encode(seat.join_message()))
        return ()

    # -- a client's own port -------------------------------------------------------------------------------
    def _on_client(self, client: _Client) -> None:
        for data, addr in _datagrams(client.udp):
            if addr == client.addr:  # rcssserver's player socket takes its own client's datagrams only
                self._from_client(client, data)
            if client.seat.gone:
                break

    def _from_client(self, client: _Client, data: bytes) -> None:
        if not client.seat.seated:
            return  # the server has not answered its init yet: rcssserver reads nothing before it
        out = client.seat.on_datagram(data)
        for text in out.texts:
            self._send_to(client.udp, client.addr, text)
        for msg in out.to_server:
            client.link.send(encode(msg))
        if client.seat.gone:
            self._drop(client)

    # -- our server ------------------------------------------------------------------------------------
    def _on_server(self, client: _Client, data: bytes) -> None:
        """One frame of our server for ``client``: its texts to the client, the seat's messages back."""
        if client.addr not in self.clients:
            return  # dropped while the frame was under way
        seat = client.seat
        see = seat.on_see_frame(data)
        if see is not None:
            for text in see.texts:
                self._send_to(client.udp, client.addr, text)
            return
        try:
            msg = percept(data) if seat.seated else decode_for_player(data)
        except ProtocolError as exc:  # a newer server's message type: ignored, as a client must
            log.info("%s: a server message was not understood: %s", seat.describe(), exc.message,
                     extra={KIND_ATTR: ("undecodable", exc.code)})
            return
        was_seated = seat.seated
        out = seat.on_server(msg)
        # a refusal comes from the init port, everything after the init from the client's own port
        sock = client.udp if seat.seated or was_seated else self.udp
        for text in out.texts:
            self._send_to(sock, client.addr, text)
        for reply in out.to_server:
            client.link.send(encode(reply))
        if seat.seated and not was_seated:
            self.versions[(seat.team, seat.unum)] = seat.version
            log.info("%s seated", seat.describe())
        if seat.gone:
            self._drop(client)
        elif msg.TYPE == THINK:  # the client's last percept of the cycle: its cycle's datagrams go now
            self.flush()

    def _send_to(self, sock: socket.socket, addr: tuple[str, int], text: str) -> None:
        """One datagram, NUL-terminated as rcssserver's (``std::ends``), sent at the next :meth:`flush`."""
        self.outgoing.append((sock, text.encode(TEXT_ENCODING) + b"\0", addr))

    def flush(self) -> None:
        """Send the datagrams written since the last flush, in order, back to back: a client wakes once
        for its percepts of a cycle rather than once for each (the front flushes at each client's
        ``think``, the loop that serves the front before it waits). A client that does not read loses
        them."""
        outgoing, self.outgoing = self.outgoing, []
        for sock, data, addr in outgoing:
            try:
                sock.sendto(data, addr)
            except OSError as exc:
                if exc.errno not in (errno.EAGAIN, errno.ECONNREFUSED, errno.ENOBUFS, errno.EBADF):
                    raise

    def _drop(self, client: _Client) -> None:
        if self.clients.pop(client.addr, None) is None:
            return
        self.names.leave(client.seat.team)
        self.unwatch(client.udp.fileno())
        client.udp.close()
        if client.link is not None:
            client.link.close()
        log.info("%s left", client.seat.describe())


# The messages of every cycle, read from our server's frames without building and checking each field's
# value (the server wrote them; see and sense_body from its kernels, docs/protocol.md §6): attributes of
# the decoded map, which is what the seat's rendering reads. Others are decoded in full.
_PERCEPT_TYPES = {"see": m.See, "sense_body": m.SenseBody, "hear": m.Hear, "think": m.Think}
THINK = m.Think.TYPE


def percept(data: bytes) -> Message | SimpleNamespace:
    """A frame from our server to a seated client: one of the cycle's percepts as a namespace of its
    fields with ``TYPE`` (about a sixth of the full decoder's time for a see), anything else decoded in
    full (``ProtocolError`` for what is not a message)."""
    try:
        fields = msgpack.unpackb(data, use_list=False)
        kind = fields.pop("type")
        cls = _PERCEPT_TYPES[kind]
    except Exception:
        return decode_for_player(data)
    return SimpleNamespace(TYPE=cls.TYPE, **fields)


def _datagrams(sock: socket.socket):
    """At most READS_PER_ROUND waiting datagrams of ``sock`` (a flooding client cannot hold the loop),
    each cut to rcssserver's receive buffer, as rcssserver cuts it."""
    for _ in range(READS_PER_ROUND):
        try:
            yield sock.recvfrom(MAX_DATAGRAM_BYTES)
        except BlockingIOError:
            return
        except ConnectionRefusedError:  # an ICMP error of an earlier send to a client that is gone
            continue


def serve(config: FrontConfig, stopped: Callable[[], bool], on_ready: Callable[[int], None] | None = None) -> None:
    """A front of its own: bind, announce the port, serve until ``stopped()``, close."""
    front = Front(config)
    try:
        port = front.bind()
        if on_ready is not None:
            on_ready(port)
        front.run(stopped)
    finally:
        front.close()
