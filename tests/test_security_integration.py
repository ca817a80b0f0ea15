"""CURVE authentication with real processes (protocol/security.py, docs/protocol.md 14): an arena started
with ``--keys`` plays whole episodes for its authorised players, coach and monitor, while a client
without a key, or with a key the arena does not know, gets nothing and the game goes on; ``keepaway
run --keys`` and the trainer's arenas play exactly the episodes of the plain game."""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest
import zmq

from conftest import keepaway_command, read_until_match
from keepaway.protocol import PROTOCOL_VERSION, encode
from keepaway.protocol import messages as m
from keepaway.protocol.arena import RunEpisodes
from keepaway.protocol.endpoints import MONITOR_FRAME_TOPIC
from keepaway.protocol.security import KeyDir, create_keys, exposure_warning, no_answer, secure_client
from keepaway.runner import distributed
from keepaway.runner.distributed import DistributedBackend
from keepaway.runner.job import Behaviours
from keepaway.runner.launch import ArenaFailure
from test_run import run_json
from keepaway.trainer.train import TrainConfig

ARENA_RE = re.compile(r"arena=(tcp://\S+)\n")
SILENCE_MS = 3000  # what a refused client waits for an answer it never gets
PROCESS_TIMEOUT_S = 300


@pytest.fixture
def keys(tmp_path):
    """The arena's keys, with a bundle for machine "laptop"."""
    create_keys(tmp_path / "keys", ["laptop"])
    return tmp_path / "keys"


@pytest.fixture
def intruder(tmp_path, keys):
    """A keys directory with the arena's public key but a client pair the arena never authorised."""
    create_keys(tmp_path / "intruder")
    shutil.copy(keys / "server.key", tmp_path / "intruder" / "server.key")
    return tmp_path / "intruder"


def client(ctx, kind, endpoint, keys=None):
    sock = ctx.socket(kind)
    sock.linger = 0
    secure_client(sock, None if keys is None else KeyDir.open(keys))
    if kind == zmq.SUB:
        sock.setsockopt(zmq.SUBSCRIBE, b"")
    sock.connect(endpoint)
    return sock


def test_an_arena_with_keys_plays_for_its_authorised_clients_and_gives_others_nothing(processes, tmp_path, keys,
                                                                                      intruder):
    srv = processes.start_server(tmp_path, "--keys", str(keys), "--episodes", "3")
    coach = processes.popen(keepaway_command("coach", "--server", srv.coach_endpoint, "--arena-port", "0",
                                             "--keys", str(keys)), stdout=subprocess.PIPE)
    arena = read_until_match(coach.stdout, ARENA_RE, 60).group(1)
    ctx = zmq.Context()
    try:
        watcher = client(ctx, zmq.SUB, srv.monitor_endpoint, keys / "clients" / "laptop")
        strangers = {  # the players, coach, monitor and arena ports, without a key and with an unknown one
            "plain player": (client(ctx, zmq.DEALER, srv.players_endpoint), m.Init(team="takers", client="x")),
            "plain coach": (client(ctx, zmq.DEALER, srv.coach_endpoint),
                            m.CoachInit(version=PROTOCOL_VERSION, client="x")),
            "intruding coach": (client(ctx, zmq.DEALER, srv.coach_endpoint, intruder),
                                m.CoachInit(version=PROTOCOL_VERSION, client="x")),
            "plain trainer": (client(ctx, zmq.DEALER, arena), RunEpisodes(episodes=1)),
            "intruding trainer": (client(ctx, zmq.DEALER, arena, intruder), RunEpisodes(episodes=1)),
            "plain monitor": (client(ctx, zmq.SUB, srv.monitor_endpoint), None),
            "intruding monitor": (client(ctx, zmq.SUB, srv.monitor_endpoint, intruder), None),
        }
        for sock, hello in strangers.values():
            if hello is not None:
                sock.send(encode(hello))
        intruding_player = processes.popen(
            keepaway_command("player", "--team", "takers", "--server", srv.players_endpoint, "--keys", str(intruder),
                             "--connect-timeout", "3"), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        assert intruding_player.wait(PROCESS_TIMEOUT_S) == 2
        assert intruding_player.stderr.read().decode().strip() == \
            f"keepaway player: {no_answer(srv.players_endpoint, 3)}"
        players = [processes.popen(keepaway_command("player", "--team", team, "--server", srv.players_endpoint,
                                                    "--keys", str(keys / "clients" / "laptop" if i == 0 else keys)),
                                   stderr=subprocess.PIPE)
                   for i, team in enumerate(["keepers"] * 3 + ["takers"] * 2)]
        assert watcher.poll(PROCESS_TIMEOUT_S * 1000), "the authorised monitor saw no frame"
        assert watcher.recv_multipart()[0] == MONITOR_FRAME_TOPIC
        for name, (sock, _) in strangers.items():
            assert not sock.poll(SILENCE_MS if name == "plain player" else 0), f"the {name} got an answer"
        assert srv.wait(PROCESS_TIMEOUT_S) == 0, srv.stderr_text()[-3000:]
        for proc in players + [coach]:
            assert proc.wait(PROCESS_TIMEOUT_S) == 0
    finally:
        ctx.destroy(linger=0)
    kwy = [l.split() for l in (srv.log_dir / "keepaway.kwy").read_text().splitlines() if l and l[0] != "#"]
    assert [int(row[0]) for row in kwy] == [1, 2, 3]
    refused = re.findall(r"refused a CURVE handshake from 127\.0\.0\.1: key (\S+) is not in (\S+)", srv.stderr_text())
    intruder_key = KeyDir.open(intruder).client_pair()[0].decode()
    assert refused and {key for key, _ in refused} == {intruder_key}
    assert {folder for _, folder in refused} == {str(keys / "authorized")}
    assert exposure_warning("127.0.0.1") not in srv.stderr_text()


def test_keepaway_run_with_keys_plays_the_plain_games_episodes(processes, tmp_path, keys):
    args = ["--episodes", "2", "--seed", "3"]
    secured = run_json(processes, *args, "--keys", str(keys), "--out", str(tmp_path / "curve"))
    embedded = run_json(processes, *args, "--mode", "embedded", "--out", str(tmp_path / "embedded"))
    assert [e["episode"] for e in secured["episodes"]] == [1, 2]
    assert secured["episodes"] == embedded["episodes"]
    assert '"keys": "%s"' % keys in (tmp_path / "curve" / "keepaway.jsonl").read_text().splitlines()[0]


def test_a_server_bound_beyond_loopback_without_keys_says_so_in_one_line(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--host", "0.0.0.0")
    srv.proc.terminate()
    assert srv.wait() == 0
    assert srv.stderr_text().count(exposure_warning("0.0.0.0")) == 1


@pytest.mark.slow
def test_a_trainer_drives_keyed_arenas_and_one_without_the_key_gets_no_answer(tmp_path, keys, monkeypatch):
    game = TrainConfig().game()
    job = Behaviours("handcoded", "handcoded")
    with DistributedBackend.start_local(game, 1, tmp_path, "classic", chunk_episodes=2, keys=keys) as backend:
        played = backend.play(job, 11, 2, "greedy")[0]
        monkeypatch.setattr(distributed, "ATTACHED_TIMEOUT_S", 2.0)
        keyless = DistributedBackend.attach(game, [backend.arenas[0].endpoint])
        try:
            with pytest.raises(ArenaFailure, match=r"no answer for \d+ s; .*\(--keys\)"):
                keyless.play(job, 11, 2, "greedy")
        finally:
            keyless.close(stop=False)
    assert len(played.episodes) == 2
    with DistributedBackend.start_local(game, 1, tmp_path / "plain", "classic", chunk_episodes=2) as plain:
        assert plain.play(job, 11, 2, "greedy")[0].episodes == played.episodes


def first_frame(url: str, timeout_s: float) -> dict:
    """The first game frame a viewer page's WebSocket sends (aiohttp's client, as a page would open it)."""
    aiohttp = pytest.importorskip("aiohttp", reason="the viewer needs the view extra (aiohttp)")
    import asyncio

    async def read() -> dict:
        async with aiohttp.ClientSession() as session, session.ws_connect(url + "ws") as ws:
            while True:
                message = await ws.receive_json(timeout=timeout_s)
                if message.get("type") == "frame":
                    return message

    return asyncio.run(asyncio.wait_for(read(), timeout_s))


def test_run_view_with_keys_follows_the_keyed_arena(processes, tmp_path, keys):
    # The viewer that `keepaway run --view --keys` starts presents the arena's client key to the monitor
    # port, which takes no client without one.
    run = processes.popen(keepaway_command("run", "--view", "--realtime", "--keys", str(keys), "--episodes", "1000",
                                           "--no-progress", "--out", str(tmp_path)),
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    url = read_until_match(run.stderr, re.compile(r"watch the arena at (http://127\.0\.0\.1:\d+/)\n"),
                           PROCESS_TIMEOUT_S).group(1)
    frame = first_frame(url, 60.0)
    assert frame["cycle"] >= 0 and len(frame["players"]) == 5 and frame["hold_s"] is not None  # joined midway


def test_the_environment_attached_to_a_keyed_server_plays_with_the_keys(processes, tmp_path, keys):
    from keepaway.env import parallel_env
    from test_env import handcoded_pass_choice, play

    server = processes.start_server(tmp_path, "--keys", str(keys), "--mode", "sync", "--seed", "4",
                                    "--cycle-timeout", "600")
    for _ in range(2):
        processes.popen(keepaway_command("player", "--team", "takers", "--server", server.players_endpoint,
                                         "--seed", "4", "--keys", str(keys)))
    env = parallel_env(server=server.players_endpoint, keys=keys)
    try:
        returns = [ret for ret, _ in play(env, 2, handcoded_pass_choice(env), seed=4)]
    finally:
        env.close()
    assert len(returns) == 2 and min(returns) > 0.0
    assert server.proc.poll() is None, server.stderr_text()
