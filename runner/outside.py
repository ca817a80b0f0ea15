"""Keepers whose decisions are made outside (``agents.player``, "Decisions made outside"), played cycle by
cycle until one of them waits: in an embedded arena, or attached to a running server as its clients.

Both give ``keepaway.env`` the same surface: ``keepers`` (the ``PlayerAgent``s in uniform-number order),
``advance()`` (play until some keeper waits, None, or the running episode ends: its end cycle),
``send(index, command)`` (a waiting keeper's command, from ``PlayerAgent.act``), ``episode_start`` (the
cycle the running episode started) and ``close()``. The players' agents are the project's own in both;
the embedded arena exchanges the distributed mode's messages in this process (``runner.embedded``), the
attached keepers speak the protocol to a real server over ZeroMQ (docs/protocol.md), so the same choices
give the same play.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Collection
from pathlib import Path

from keepaway.agents.player import EPISODE_MESSAGE, KICK_OFF_MESSAGE, PlayerAgent
from keepaway.protocol import encode
from keepaway.protocol import messages as m
from keepaway.protocol.messages import SERVER_SILENCE_S
from keepaway.runner.embedded import ArenaSpec, EmbeddedGame

log = logging.getLogger("keepaway.env")
CLIENT_NAME = "keepaway-env"


class EmbeddedKeepers:
    """The keepers of an embedded arena of ``spec`` (module docstring)."""

    def __init__(self, spec: ArenaSpec, outside: Collection[str]) -> None:
        self.game = EmbeddedGame(spec, outside=outside)
        self.slots = [slot for slot, player in self.game.players if player.is_keeper]
        self.keepers = [player for _, player in self.game.players if player.is_keeper]
        self.episode_start = self.game.arena.cycle  # the kick-off
        self._mid_cycle = False

    def advance(self) -> int | None:
        """Finish the cycle the keepers' decisions were awaited in and play on until some keeper waits
        (None) or the running episode ends (its end cycle, where the next one starts)."""
        game = self.game
        while True:
            if self._mid_cycle:
                if any(k.awaiting is not None for k in self.keepers):
                    return None
                self._mid_cycle = False
                record = game.step()
                if record is not None:
                    self.episode_start = record.end_cycle
                    return record.end_cycle
            game.perceive()
            game.think()
            self._mid_cycle = True

    def send(self, index: int, frame: bytes) -> None:
        """Keeper ``index``'s command frame (``PlayerAgent.act_frame``), to the arena."""
        self.game.submit(self.slots[index], frame)

    def close(self) -> None:
        """Nothing to release: the arena lives in this process."""


class AttachedKeepers:
    """Keepers 1..K of the synchronous ``keepaway server`` at ``endpoint`` (its players port), each a
    ``PlayerAgent`` built by ``make_agent()`` on its own DEALER socket, as ``keepaway player`` connects
    (``agents/cli.py``), over CURVE with ``keys`` (a keys directory: the server's public key and a client
    pair it authorised, docs/protocol.md §15). The server must run in synchronous mode with a
    ``--cycle-timeout`` longer than the caller's longest think between two steps: it waits for the
    keepers' commands as for any player's.
    Raises RuntimeError (one line) when the server refuses a keeper, is silent for
    :data:`SERVER_SILENCE_S`, or shuts down."""

    def __init__(self, endpoint: str, n_keepers: int, make_agent: Callable[[], PlayerAgent],
                 keys: str | Path | None = None) -> None:
        import zmq

        from keepaway.protocol.endpoints import configure
        from keepaway.protocol.security import open_keys, secure_client

        key_dir = open_keys(keys)

        self._zmq = zmq
        self.ctx = zmq.Context()
        self.sockets = []
        self.keepers: list[PlayerAgent] = []
        self.episode_start = 0
        self._thought = [-1] * n_keepers  # the cycle of each keeper's last think
        self._ended: int | None = None
        try:
            for unum in range(1, n_keepers + 1):
                sock = self.ctx.socket(zmq.DEALER)
                configure(sock)
                secure_client(sock, key_dir)
                sock.connect(endpoint)
                self.sockets.append(sock)
                agent = make_agent()
                self.keepers.append(agent)
                sock.send(encode(m.Init(team="keepers", unum=unum, client=CLIENT_NAME)))
            for index, agent in enumerate(self.keepers):
                while not agent.ready:
                    self._take(index, self._receive(index))
                if agent.mode != "sync":
                    raise RuntimeError(f"the server at {endpoint} runs in {agent.mode} mode; an attached "
                                       "environment needs the synchronous mode")
        except BaseException:
            self.close()
            raise

    def _receive(self, index: int) -> m.Message:
        """The next message of keeper ``index``'s socket, decoded (a bad frame is logged and skipped)."""
        from keepaway.protocol.errors import ProtocolError
        from keepaway.protocol.messages import decode_for_player

        sock = self.sockets[index]
        while True:
            if not sock.poll(int(SERVER_SILENCE_S * 1000)):
                raise RuntimeError(f"no message from the server for {SERVER_SILENCE_S:g} s")
            try:
                return decode_for_player(sock.recv())
            except ProtocolError as exc:
                log.warning("dropped a message from the server: %s: %s", exc.code, exc.message)

    def _take(self, index: int, msg: m.Message) -> None:
        """One message for keeper ``index``: the episode boundaries noted, the agent fed, its command sent."""
        agent = self.keepers[index]
        if isinstance(msg, m.Shutdown):
            raise RuntimeError(f"the server shut down: {msg.reason}")
        if isinstance(msg, m.Error):
            if not agent.ready:
                raise RuntimeError(f"the server refused keeper {index + 1}: {msg.code}: {msg.message}")
            log.warning("server error at cycle %d: %s: %s", msg.cycle, msg.code, msg.message)
            return
        if isinstance(msg, m.Hear) and msg.sender == "referee" and msg.cycle > self.episode_start:
            if msg.message == EPISODE_MESSAGE:
                self._ended = self.episode_start = msg.cycle
            elif msg.message == KICK_OFF_MESSAGE and self._thought[index] < 0:
                self.episode_start = msg.cycle
        if isinstance(msg, m.Think):
            self._thought[index] = msg.cycle
        command = agent.message_frame(msg)
        if command is not None:
            self.send(index, command)

    def advance(self) -> int | None:
        """Read the keepers' messages (never those of a waiting keeper: the server waits for it) until the
        running episode ends (its end cycle) or some keeper waits and every other one has thought in that
        cycle (None)."""
        while True:
            if self._ended is not None:
                ended, self._ended = self._ended, None
                return ended
            waiting = [k.awaiting.cycle for k in self.keepers if k.awaiting is not None]
            if waiting and all(k.awaiting is not None or self._thought[i] >= waiting[0]
                               for i, k in enumerate(self.keepers)):
                return None
            poller = self._zmq.Poller()
            for index, sock in enumerate(self.sockets):
                if self.keepers[index].awaiting is None:
                    poller.register(sock, self._zmq.POLLIN)
            ready = dict(poller.poll(int(SERVER_SILENCE_S * 1000)))
            if not ready:
                raise RuntimeError(f"no message from the server for {SERVER_SILENCE_S:g} s")
            for index, sock in enumerate(self.sockets):
                if sock in ready:
                    self._take(index, self._receive(index))

    def send(self, index: int, frame: bytes) -> None:
        """Keeper ``index``'s command frame (``PlayerAgent.act_frame``), to the server."""
        self.sockets[index].send(frame)

    def close(self) -> None:
        """Say bye for every keeper that joined and close the sockets."""
        for agent, sock in zip(self.keepers, self.sockets):
            if agent.ready:
                sock.send(encode(m.Bye()), self._zmq.NOBLOCK)
        for sock in self.sockets:
            sock.close(linger=500)
        self.sockets = []
        self.ctx.term()


__all__ = ["AttachedKeepers", "EmbeddedKeepers"]
