"""``keepaway player``: one keeper or taker process over ZeroMQ (docs/design.md, "Processes and sockets").

The socket edge of :class:`agents.player.PlayerAgent` (the server's socket edge has the same shape): one DEALER
socket (LINGER 0 but for a bounded wait after ``bye``, the protocol's size limit), one poll loop, every
frame decoded by ``protocol`` before the agent sees it. Exit codes: 0 when the server shuts down or on
SIGTERM/SIGINT (after saying ``bye``), 2 when the player cannot start (bad policy file, no server within
``--connect-timeout``, ``init`` refused, ``reconnect`` refused for that long), 4 when a joined player's
server has sent nothing for ``--server-silence`` seconds (it sends a ``waiting`` every second while no
cycle is played, so only a dead or frozen server is silent that long). That silence is the time the player
waited in receives that found nothing, not the time on the clock: a player that was itself frozen (SIGSTOP,
then SIGCONT) first reads what waits for it, and its own sleep never counts as the server's silence.
Expected conditions end with one line on stderr, never a traceback. With ``--reconnect UNUM`` the player takes
back the seat of a player of its team that is gone (crashed, killed, or given up by the server) instead of
joining anew (docs/protocol.md §12, "Rejoin"). A seat whose old client the server still waits for (a hung
process it has not yet given up after ``max_missed_cycles``, a crash it has not yet noticed) is refused with
``cannot_reconnect``; the player asks again every :data:`RECONNECT_RETRY_S` until ``--connect-timeout``,
so a replacement can be started as soon as the old process is found dead or stuck. With ``--rcss HOST:PORT``
the same agent plays on a real rcssserver instead, through the UDP edge of ``agents/rcss_client.py``, which
ends alike (``agents/edge.py``).
"""

from __future__ import annotations

import logging
import signal
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from click.core import ParameterSource

from keepaway.agents.edge import (
    EXIT_OK,
    EXIT_SERVER_SILENT,
    EXIT_START_FAILED,
    MAX_SILENT_WAIT_S,
    POLL_MS,
    RECONNECT_RETRY_S,
    PlayerExit,
    StopFlag,
)
from keepaway.agents.rcss_client import DEFAULT_VERSION as RCSS_DEFAULT_VERSION
from keepaway.agents.rcss_client import rcss_address, run_rcss_player
from keepaway.core.options import FiniteFloatRange, configure_logging
from keepaway.protocol.endpoints import DEFAULT_PORTS, parse_endpoint
from keepaway.protocol.messages import MAX_SEED, SERVER_SILENCE_S
from keepaway.protocol.security import KeyDir, SecurityError, keys_option, no_answer, open_keys, secure_client
from keepaway.rcss.read import VERSIONS as RCSS_VERSIONS

# Sockets have LINGER 0, except after a bye: closing then waits this long for the bye to leave, so it
# is not discarded unsent (and never longer, should the server be gone).
BYE_LINGER_MS = 1000
CLIENT_NAME = "keepaway-player"
DEFAULT_SERVER = f"tcp://127.0.0.1:{DEFAULT_PORTS['players']}"

if TYPE_CHECKING:
    from keepaway.agents.player import PlayerAgent

log = logging.getLogger("keepaway.player")


def run_player(agent: PlayerAgent, endpoint: str, connect_timeout_s: float, stop: StopFlag,
               reconnect: int | None = None, silence_s: float = SERVER_SILENCE_S,
               keys: KeyDir | None = None) -> int:
    """Connect (with ``keys``, over CURVE), send ``init`` (or with ``reconnect`` a uniform number,
    ``reconnect`` to it) and feed ``agent`` until the server shuts down or ``stop`` is set. Returns the
    exit code; raises :class:`PlayerExit` when the player cannot start."""
    import zmq

    from keepaway.agents.policy_file import PolicyFileError
    from keepaway.protocol import PROTOCOL_VERSION
    from keepaway.protocol import messages as m
    from keepaway.protocol.codec import encode
    from keepaway.protocol.endpoints import configure
    from keepaway.protocol.errors import ProtocolError
    from keepaway.protocol.messages import decode_for_player

    stop.in_loop = True
    ctx = zmq.Context()
    sock = ctx.socket(zmq.DEALER)
    configure(sock)
    # a blocking receive with a timeout, not a poll and then non-blocking receives: a cycle's percepts
    # arrive in a few bursts, and each wake-up then costs one call instead of a poll, a receive and a
    # failed receive
    sock.setsockopt(zmq.RCVTIMEO, POLL_MS)
    linger_ms = 0
    try:
        secure_client(sock, keys)
        sock.connect(endpoint)

        def send(msg: Any) -> None:
            send_frame(encode(msg), msg.TYPE)

        def send_frame(data: bytes, kind: str = m.Command.TYPE) -> None:
            try:
                sock.send(data, zmq.NOBLOCK)
            except zmq.Again:
                log.warning("could not send %s: the server is not reachable", kind)

        def say_bye() -> None:
            nonlocal linger_ms
            send(m.Bye())
            linger_ms = BYE_LINGER_MS

        def join() -> None:
            if reconnect is None:
                send(m.Init(team=agent.team, client=CLIENT_NAME, fullstate=agent.fullstate))
            else:
                send(m.Reconnect(version=PROTOCOL_VERSION, team=agent.team, unum=reconnect))

        join()
        joining = "init" if reconnect is None else "reconnect"
        deadline = time.monotonic() + connect_timeout_s
        silent_s = 0.0  # the server's silence: time waited in receives that found nothing (module docstring)
        retry_at: float | None = None  # when to ask for the seat again after a cannot_reconnect
        refused: str | None = None  # the last cannot_reconnect, for the message should time run out
        while True:
            if stop.signal_name is not None:
                log.info("%s: saying bye", stop.signal_name)
                if agent.ready:
                    say_bye()
                return EXIT_OK
            if not agent.ready and time.monotonic() > deadline:
                if refused is not None:
                    raise PlayerExit(EXIT_START_FAILED, f"the server refused reconnect for "
                                                        f"{connect_timeout_s:g} s: {refused}")
                raise PlayerExit(EXIT_START_FAILED, no_answer(endpoint, connect_timeout_s))
            if retry_at is not None and time.monotonic() >= retry_at:
                retry_at = None
                join()
            if agent.ready and silent_s > silence_s:
                raise PlayerExit(EXIT_SERVER_SILENT, f"the server at {endpoint} has sent nothing for "
                                                     f"{silence_s:g} s; giving it up")
            waited_from = time.monotonic()
            try:
                data = sock.recv()
            except zmq.Again:  # nothing within POLL_MS
                silent_s += min(time.monotonic() - waited_from, MAX_SILENT_WAIT_S)
                continue
            silent_s = 0.0
            taken, command = agent.take_frame(data)  # a percept or think of every cycle, without a message
            if taken:
                if command is not None:
                    send_frame(command)
                continue
            try:
                msg = decode_for_player(data)
            except ProtocolError as exc:
                log.warning("dropped a message from the server: %s: %s", exc.code, exc.message)
                continue
            if isinstance(msg, m.Shutdown):
                log.info("server shut down: %s", msg.reason)
                return EXIT_OK
            if isinstance(msg, m.Error):
                if not agent.ready and msg.code == "cannot_reconnect" and reconnect is not None:
                    if refused is None:
                        log.info("the server refused reconnect (%s); asking again every %g s for %g s",
                                 msg.message, RECONNECT_RETRY_S, connect_timeout_s)
                    refused = f"{msg.code}: {msg.message}"
                    retry_at = time.monotonic() + RECONNECT_RETRY_S
                    continue
                if not agent.ready:
                    raise PlayerExit(EXIT_START_FAILED,
                                     f"the server refused {joining}: {msg.code}: {msg.message}")
                log.warning("server error at cycle %d: %s: %s", msg.cycle, msg.code, msg.message)
                continue
            try:
                command = agent.message_frame(msg)
            except (PolicyFileError, ValueError) as exc:
                if agent.ready and not isinstance(msg, m.InitOk):
                    raise
                say_bye()
                raise PlayerExit(EXIT_START_FAILED, str(exc)) from None
            if isinstance(msg, m.InitOk):
                log.info("joined as %s %d (%s mode)", agent.team, agent.unum, agent.mode)
            if command is not None:
                send_frame(command)
            for report in agent.pending_reports():
                send(report)
    finally:
        sock.close(linger=linger_ms)
        ctx.term()


@click.command("player")
@click.option("--team", type=click.Choice(["keepers", "takers"]), required=True, help="The team to join.")
@click.option("--pass", "pass_policy", type=click.Choice(["random", "handcoded", "learned", "hold"]),
              default="handcoded", show_default=True,
              help="Keepers' Pass policy (learned: SMDP Sarsa from the policy file's Pass weights, the "
                   "keeper's own pass_keeper<k>_* ones if the file has them, or zeros without a file; greedy "
                   "until the coach's pass_mode advice).")
@click.option("--getopen", "getopen_policy",
              type=click.Choice(["random", "handcoded", "handcoded-cone", "learned"]), default="handcoded",
              show_default=True,
              help="Keepers' GetOpen policy (handcoded: the paper's rule; handcoded-cone: the framework's; "
                   "learned: the policy file's net, or the coach's).")
@click.option("--policy", "policy_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Policy file (.npz) with the learned parameters.")
@click.option("--server", "endpoint", default=DEFAULT_SERVER, show_default=True,
              help="The server's players endpoint, tcp://HOST:PORT.")
@click.option("--seed", type=click.IntRange(0, MAX_SEED), default=0, show_default=True,
              help="Seed of the player's own randomness (combined with its side and uniform number).")
@click.option("--fullstate", is_flag=True, help="Use the exact fullstate percepts instead of seeing.")
@click.option("--reconnect", type=click.IntRange(1, 11), default=None, metavar="UNUM",
              help="Take back the seat of this uniform number of the team, whose player is gone (crashed, "
                   "killed, hung, or given up by the server), instead of joining anew; while the server "
                   "still waits for the old player the player asks again every second until "
                   "--connect-timeout. The seat keeps the settings of its first init (--fullstate).")
@click.option("--connect-timeout", "connect_timeout_s", type=FiniteFloatRange(min=0.0, min_open=True), default=60.0,
              show_default=True,
              help="Seconds to wait for the server's init_ok (with --reconnect: for the seat) before giving up "
                   "(exit 2).")
@click.option("--server-silence", "silence_s", type=FiniteFloatRange(min=0.0, min_open=True),
              default=SERVER_SILENCE_S, show_default=True,
              help="Seconds spent waiting for a message from the server, in vain, after which a joined player "
                   "gives it up "
                   "(exit 4); a live server sends something at least every second.")
@keys_option
@click.option("--rcss", "rcss", default=None, metavar="HOST:PORT",
              help="Play on a real rcssserver at HOST:PORT (its player port, UDP) instead of our server, over "
                   "rcssserver's text protocol. rcssserver seats the team that joins first on the left side, "
                   "which must be the keepers: start them before the takers.")
@click.option("--rcss-version", type=click.IntRange(min(RCSS_VERSIONS), max(RCSS_VERSIONS)),
              default=RCSS_DEFAULT_VERSION, show_default=True,
              help="The rcssserver protocol version the player asks for with --rcss (from 18 on rcssserver "
                   "sends every see in step with the cycle, synch_see).")
@click.option("-v", "--verbose", count=True, help="More log output (-v info, -vv debug).")
@click.pass_context
def player_command(ctx: click.Context, team: str, pass_policy: str, getopen_policy: str, policy_path: Path | None,
                   endpoint: str, seed: int, fullstate: bool, reconnect: int | None, connect_timeout_s: float,
                   silence_s: float, keys: Path | None, rcss: str | None, rcss_version: int, verbose: int) -> None:
    """Run one Keepaway player: connect to the server, play until it ends, exit.

    Exits 0 when the server shuts down or on SIGTERM/SIGINT (after saying bye), 2 when it cannot start,
    4 when the server falls silent (--server-silence).
    """
    configure_logging(verbose)
    try:
        parse_endpoint(endpoint)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--server") from None
    if rcss is not None:
        try:
            rcss_server = rcss_address(rcss)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--rcss") from None
        for name, given in (("--server", ctx.get_parameter_source("endpoint") is not ParameterSource.DEFAULT),
                            ("--keys", keys is not None), ("--fullstate", fullstate)):
            if given:
                raise click.BadParameter(f"{name} is for our server: rcssserver speaks plain UDP and sends no "
                                         f"fullstate to a player that asks", param_hint="--rcss")
    stop = StopFlag()
    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)

    from keepaway.agents.player import PlayerAgent, compile_kernels  # here so `keepaway --help` stays light
    from keepaway.agents.policy_file import PolicyFileError, load_policy

    try:
        policy = load_policy(policy_path) if policy_path is not None else None
        agent = PlayerAgent(team, pass_policy, getopen_policy, policy=policy, seed=seed, fullstate=fullstate)
        if team == "keepers" and getopen_policy == "learned" and policy is None:
            log.warning("--getopen learned without --policy: GetOpen uses zero weights until the coach "
                        "sends a policy")
        compile_kernels()
        if rcss is None:
            code = run_player(agent, endpoint, connect_timeout_s, stop, reconnect, silence_s, open_keys(keys))
        else:
            code = run_rcss_player(agent, rcss_server, connect_timeout_s, stop, reconnect, silence_s, rcss_version)
    except (PolicyFileError, SecurityError) as exc:
        click.echo(f"keepaway player: {exc}", err=True)
        sys.exit(EXIT_START_FAILED)
    except PlayerExit as exc:
        if exc.message:
            click.echo(f"keepaway player: {exc.message}", err=True)
        sys.exit(exc.code)
    sys.exit(code)


commands = [player_command]
