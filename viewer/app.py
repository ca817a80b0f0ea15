"""``keepaway view``'s web server: one static canvas page and one WebSocket (aiohttp, asyncio).

A replay (:class:`ReplaySource`) gives each page its own :class:`viewer.frames.Replay` of the game log,
driven by the page's requests (play, pause, step, speed, episode, seek); a live view
(:class:`LiveSource`) subscribes to an arena's monitor port (docs/protocol.md §8) and relays every frame
to every page. The sockets live here; what is sent is decided in ``viewer/frames.py``.
"""

from __future__ import annotations

import asyncio
import json
import logging
import signal
from collections.abc import Callable
from pathlib import Path

import zmq
import zmq.asyncio
from aiohttp import WSMsgType, web

from keepaway.protocol import MONITOR_FRAME_TOPIC
from keepaway.protocol import messages as m
from keepaway.protocol.errors import ProtocolError
from keepaway.protocol.messages import decode_monitor
from keepaway.protocol.security import KeyDir, secure_client
from keepaway.server.game_log import GameRecord
from keepaway.viewer.frames import Replay, info_message, live_frame

log = logging.getLogger("keepaway.viewer")
PAGE = Path(__file__).parent / "static" / "index.html"
HEARTBEAT_S = 10.0  # WebSocket pings: a page that went away is noticed


class ReplaySource:
    """A game log, replayed to each page on its own clock."""

    def __init__(self, record: GameRecord, name: str, step_ms: float = 100.0) -> None:
        self.record = record
        self.name = name
        self.step_ms = step_ms

    async def start(self, app: web.Application) -> None:
        """Nothing runs between pages."""

    async def handle(self, request: web.Request) -> web.WebSocketResponse:
        ws = web.WebSocketResponse(heartbeat=HEARTBEAT_S)
        await ws.prepare(request)
        replay = Replay(self.record, self.step_ms)
        await ws.send_json(replay.info(self.name))
        await ws.send_json(replay.frame())
        clock = asyncio.create_task(self._play(ws, replay))
        try:
            async for msg in ws:
                if msg.type != WSMsgType.TEXT:
                    continue
                try:
                    replay.command(json.loads(msg.data))
                except ValueError as exc:  # json.JSONDecodeError is one
                    await ws.send_json({"type": "error", "message": str(exc)})
                    continue
                await ws.send_json(replay.frame())
        finally:
            clock.cancel()
        return ws

    @staticmethod
    async def _play(ws: web.WebSocketResponse, replay: Replay) -> None:
        """Move on one show every ``replay.interval_s`` while playing; say so when the end pauses it."""
        was_playing = replay.playing
        while not ws.closed:
            await asyncio.sleep(replay.interval_s)
            if (replay.advance() or (was_playing and not replay.playing)) and not ws.closed:
                await ws.send_json(replay.frame())
            was_playing = replay.playing


class LiveSource:
    """An arena's monitor port, relayed to every page; ``keys``: the arena's keys directory when its ports
    take only authorised CURVE clients (docs/protocol.md §15)."""

    def __init__(self, endpoint: str, region: tuple[float, float], step_ms: float = 100.0,
                 keys: KeyDir | None = None) -> None:
        self.endpoint = endpoint
        self.keys = keys
        self.region = region
        self.step_ms = step_ms
        self.pages: set[web.WebSocketResponse] = set()
        self.last: str | None = None

    async def start(self, app: web.Application) -> None:
        relay = asyncio.create_task(self._relay())

        async def stop(_app: web.Application) -> None:
            relay.cancel()

        app.on_cleanup.append(stop)

    async def handle(self, request: web.Request) -> web.WebSocketResponse:
        ws = web.WebSocketResponse(heartbeat=HEARTBEAT_S)
        await ws.prepare(request)
        await ws.send_json(info_message("live", self.endpoint, self.region))
        if self.last is not None:
            await ws.send_str(self.last)
        self.pages.add(ws)
        try:
            async for _ in ws:  # a live page only watches
                pass
        finally:
            self.pages.discard(ws)
        return ws

    async def _relay(self) -> None:
        ctx = zmq.asyncio.Context.instance()
        sock = ctx.socket(zmq.SUB)
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(zmq.SUBSCRIBE, MONITOR_FRAME_TOPIC)
        secure_client(sock, self.keys)
        sock.connect(self.endpoint)
        try:
            while True:
                topic, *rest = await sock.recv_multipart()
                try:
                    frame = decode_monitor(topic, rest[0] if len(rest) == 1 else b"")
                except ProtocolError as exc:
                    log.warning("monitor %s: %s: %s", self.endpoint, exc.code, exc.message)
                    continue
                if not isinstance(frame, m.Frame):
                    continue
                self.last = json.dumps(live_frame(frame, self.step_ms))
                pages = [ws for ws in self.pages if not ws.closed]
                await asyncio.gather(*(ws.send_str(self.last) for ws in pages), return_exceptions=True)
        finally:
            sock.close(linger=0)


async def index(_request: web.Request) -> web.FileResponse:
    return web.FileResponse(PAGE, headers={"Cache-Control": "no-store"})


def make_app(source: ReplaySource | LiveSource) -> web.Application:
    app = web.Application()
    app.router.add_get("/", index)
    app.router.add_get("/ws", source.handle)
    app.on_startup.append(source.start)
    return app


def serve(source: ReplaySource | LiveSource, host: str, port: int, announce: Callable[[str], None]) -> None:
    """Serve until SIGINT or SIGTERM; ``announce`` gets the page's URL once the port is bound (port 0: a
    free one)."""

    async def main() -> None:
        runner = web.AppRunner(make_app(source), access_log=None)
        await runner.setup()
        site = web.TCPSite(runner, host, port)
        await site.start()
        bound = runner.addresses[0][1]
        announce(f"http://{host}:{bound}/")
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        try:
            await stop.wait()
        finally:
            await runner.cleanup()

    asyncio.run(main())


__all__ = ["LiveSource", "ReplaySource", "make_app", "serve"]
