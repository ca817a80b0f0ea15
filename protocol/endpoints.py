"""ZeroMQ endpoints and socket options shared by the server and every client.

The ports mirror rcssserver's numbering (6000 players, 6001/6002 coach/monitor) plus
the coach's arena port (docs/protocol.md §1). Socket settings live here so both ends agree
on them: ``configure`` is called on every socket before it binds or connects.
"""

from __future__ import annotations

import zmq

DEFAULT_PORTS: dict[str, int] = {"players": 6000, "coach": 6001, "monitor": 6002, "arena": 6003}

DEFAULT_MAX_MESSAGE_BYTES = 4 * 1024 * 1024
"""Largest frame a socket accepts (ZMQ_MAXMSGSIZE); bounds ``report`` payloads such as weight snapshots."""

MAX_MESSAGE_BYTES_LIMIT = 64 * 1024 * 1024
"""The largest ``max_message_bytes`` a server takes: its ports then hold at most 4 x 64 MiB of one frame
before ZeroMQ closes the sender's connection, and a coach's advice fits a trainer's request
(``protocol.arena.ARENA_REQUEST_MAX_BYTES``)."""

MONITOR_FRAME_TOPIC = b"frame"
"""Monitor PUB topic: one ``frame`` message (the true state) per cycle."""

MONITOR_EPISODE_TOPIC = b"episode"
"""Monitor PUB topic: one ``episode_end`` message per finished episode."""


def configure(socket: zmq.Socket, max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> None:
    """Set the options every keepaway socket uses.

    * ``LINGER 0``: closing never waits for unsent messages, so a process can always exit.
    * ``MAXMSGSIZE``: a peer that sends a larger frame is disconnected by ZeroMQ before any byte of it
      reaches the decoder.
    * ROUTER sockets only, ``ROUTER_MANDATORY``: a send to an identity that is not (or no longer)
      connected raises ``zmq.ZMQError`` (``EHOSTUNREACH``) instead of being dropped silently, so the
      server notices a vanished player; with ``zmq.NOBLOCK`` a peer whose queue is full raises
      ``zmq.Again``. Callers of ``send`` on a ROUTER must handle both.
    """
    socket.setsockopt(zmq.LINGER, 0)
    socket.setsockopt(zmq.MAXMSGSIZE, max_message_bytes)
    if socket.type == zmq.ROUTER:
        socket.setsockopt(zmq.ROUTER_MANDATORY, 1)


def _host_for_url(host: str) -> str:
    """IPv6 literals need brackets inside a ZeroMQ tcp:// endpoint."""
    return f"[{host}]" if ":" in host and not host.startswith("[") else host


def bind(socket: zmq.Socket, host: str, port: int) -> int:
    """Bind ``socket`` to ``tcp://host:port`` and return the port actually bound.

    ``port`` 0 asks the operating system for a free port (ZeroMQ's ``*`` wildcard); the chosen one is
    read back from the socket's last endpoint, so tests and parallel arenas never collide. ``host`` may be
    ``*`` for every interface.
    """
    if not 0 <= port <= 65535:
        raise ValueError(f"port {port} is outside 0..65535")
    socket.bind(f"tcp://{_host_for_url(host)}:{port if port else '*'}")
    last = socket.getsockopt(zmq.LAST_ENDPOINT)
    return parse_endpoint(last.decode() if isinstance(last, bytes) else str(last))[1]


def connect_endpoint(host: str, port: int) -> str:
    """The endpoint a client connects to, e.g. ``connect_endpoint("127.0.0.1", 6000)``."""
    if not 1 <= port <= 65535:
        raise ValueError(f"port {port} is outside 1..65535")
    return f"tcp://{_host_for_url(host)}:{port}"


def parse_endpoint(endpoint: str) -> tuple[str, int]:
    """``"tcp://127.0.0.1:6000"`` -> ``("127.0.0.1", 6000)``; IPv6 brackets are removed.

    Raises ``ValueError`` for anything but a ``tcp://host:port`` endpoint with a numeric port.
    """
    prefix = "tcp://"
    if not endpoint.startswith(prefix):
        raise ValueError(f"not a tcp:// endpoint: {endpoint!r}")
    host, sep, port_text = endpoint[len(prefix):].rpartition(":")
    if not sep or not host or not port_text.isdigit() or not port_text.isascii():
        raise ValueError(f"endpoint {endpoint!r} is not tcp://host:port")
    port = int(port_text)
    if port > 65535:
        raise ValueError(f"port {port} in {endpoint!r} is outside 0..65535")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    return host, port
