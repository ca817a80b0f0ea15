"""``keepaway player --rcss HOST:PORT``: the player on a real rcssserver, over its UDP text protocol.

The converse of our server: the same :class:`agents.player.PlayerAgent` plays, fed our protocol's messages
read from rcssserver's text by ``rcss.read``, and its commands go back as text (``rcss.commands``). One
UDP socket and one receive loop, as ``agents/cli.py`` has one DEALER socket and one poll loop, with the same
exit codes and one-line errors (``agents.edge``): 0 on SIGTERM/SIGINT (after ``(bye)``), 2 when the player
cannot start, 4 when rcssserver has sent nothing for ``--server-silence`` seconds (rcssserver sends
percepts every cycle, before the kick-off too, and says nothing when it ends: a player whose server is gone
ends this way).

**Joining** (rcssserver ``src/stadium.cpp``, ``initPlayer``): ``(init TEAM (version V))`` goes to the
server's port once (rcssserver seats a player for every ``init`` it reads, so a repeated one could take two
seats); the answer comes from a port of the player's own, where every later message of the player goes
and from where alone datagrams are taken. ``--reconnect UNUM`` sends ``(reconnect TEAM UNUM)`` instead;
rcssserver refuses it while the ball is in play (``cannot_reconnect_while_playon``), and the player asks
again every second until ``--connect-timeout``.

**Sides.** rcssserver seats the first team to join on the left and the second on the right; its Keepaway
referee (``referee.cpp``, ``KeepawayRef``) takes the left team for the keepers, as our players do. So the
keepers must join first, as keepaway-0.6's ``keepaway.sh`` starts them (its players join as teams
``keepers`` and ``takers`` too, so ours and theirs mix): a player seated on the wrong side says ``(bye)`` and
ends with exit code 2.

**Each cycle** the agent takes the cycle's percepts. In synchronous mode (rcssserver's ``synch_mode``)
it answers every ``(think)`` with one datagram, its commands and ``(done)``, as keepaway-0.6's players do
(``player/KeepawayPlayer.cc``); in real-time mode its commands go out when it decides, on the cycle's
``sense_body``. Every message ends with the NUL byte rcssserver expects from protocol version 8 on.

**Late sees.** Below version 18 rcssserver's synchronous timer (``synctimer.cpp``) sends a player's see
when the player's own timer says so, every 150 ms of simulated time counted from when it joined, and the
``(think)`` 80 ms into each cycle (``synch_offset``): a see due in the cycle's last 20 ms comes after the
``(think)`` it belongs to, and the agent takes it in at the next cycle's decision. Which players' timers do
so is drawn when they join (one in four, for every other see); keepaway-0.6's players draw the same. The
player logs, when it ends, how many of its sees came late.
"""

from __future__ import annotations

import logging
import socket
import time
from typing import TYPE_CHECKING

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
from keepaway.core.log_limit import KIND_ATTR, RepeatLimit
from keepaway.protocol import messages as m
from keepaway.protocol.endpoints import parse_endpoint
from keepaway.protocol.messages import SERVER_SILENCE_S
from keepaway.rcss.commands import commands_text
from keepaway.rcss.read import MAX_TEXT_CHARS, Joined, PlayerReader
from keepaway.rcss.read import repeat_limit as read_repeat_limit

if TYPE_CHECKING:
    from keepaway.agents.player import PlayerAgent

# The protocol version a player asks for. 15 sends every percept our players take and keeps rcssserver's
# asynchronous see timer, the one keepaway-0.6's players (version 12) and our server's synchronous mode
# play with; from 18 on rcssserver turns synch_see on for every player (src/player.cpp).
DEFAULT_VERSION = 15
SIDE_OF_TEAM = {"keepers": "l", "takers": "r"}
CANNOT_RECONNECT = "cannot_reconnect_while_playon"  # rcssserver's refusal of a reconnect in play

log = logging.getLogger("keepaway.player.rcss")
repeat_limit = RepeatLimit()
log.addFilter(repeat_limit)


def rcss_address(text: str) -> tuple[str, int]:
    """``"127.0.0.1:6000"`` -> ``("127.0.0.1", 6000)``; ValueError (one line) for anything else."""
    try:
        return parse_endpoint(f"tcp://{text}")
    except ValueError:
        raise ValueError(f"{text!r} is not HOST:PORT") from None


def run_rcss_player(agent: PlayerAgent, address: tuple[str, int], connect_timeout_s: float, stop: StopFlag,
                    reconnect: int | None = None, silence_s: float = SERVER_SILENCE_S,
                    version: int = DEFAULT_VERSION) -> int:
    """Join rcssserver at ``address`` (``init`` with protocol ``version``, or with ``reconnect`` a uniform
    number, ``reconnect`` to it) and feed ``agent`` until ``stop`` is set. Returns the exit code; raises
    :class:`PlayerExit` when the player cannot start or rcssserver falls silent (module docstring)."""
    from keepaway.agents.policy_file import PolicyFileError

    where = f"rcssserver at {address[0]}:{address[1]}"
    try:
        init_port = socket.getaddrinfo(address[0], address[1], socket.AF_INET, socket.SOCK_DGRAM)[0][4]
    except OSError as exc:
        raise PlayerExit(EXIT_START_FAILED, f"cannot reach {where}: {exc.strerror or exc}") from None
    reader = PlayerReader(agent.team, reconnect)
    stop.in_loop = True
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.settimeout(POLL_MS / 1000)
    server = init_port  # where the player's messages go: the init port, then the player's own

    def send(text: str) -> None:
        try:
            sock.sendto(text.encode("ascii") + b"\0", server)
        except (OSError, UnicodeEncodeError) as exc:
            log.warning("could not send to %s: %s", where, exc, extra={KIND_ATTR: ("send",)})

    def join() -> None:
        send(f"(init {agent.team} (version {version}))" if reconnect is None
             else f"(reconnect {agent.team} {reconnect})")

    try:
        join()
        deadline = time.monotonic() + connect_timeout_s
        silent_s = 0.0  # the server's silence, counted as agents/cli.py counts it
        retry_at: float | None = None  # when to ask for the seat again after a refused reconnect
        refused: str | None = None  # the last refusal of a reconnect, for the message should time run out
        thought = -1  # the cycle of the last (think)
        sees = late = 0  # the sees after the kick-off, and those that came after their cycle's (think)
        while True:
            if stop.signal_name is not None:
                log.info("%s: saying bye", stop.signal_name)
                if reader.joined is not None:
                    send("(bye)")
                return EXIT_OK
            if not agent.ready and time.monotonic() > deadline:
                if refused is not None:
                    raise PlayerExit(EXIT_START_FAILED, f"{where} refused reconnect for {connect_timeout_s:g} s: "
                                                        f"{refused}")
                raise PlayerExit(EXIT_START_FAILED, f"no answer from {where} within {connect_timeout_s:g} s: "
                                                    f"is it running?")
            if retry_at is not None and time.monotonic() >= retry_at:
                retry_at = None
                join()
            if reader.joined is not None and silent_s > silence_s:
                raise PlayerExit(EXIT_SERVER_SILENT, f"{where} has sent nothing for {silence_s:g} s; giving it up")
            waited_from = time.monotonic()
            try:
                data, sender = sock.recvfrom(MAX_TEXT_CHARS)
            except TimeoutError:
                silent_s += min(time.monotonic() - waited_from, MAX_SILENT_WAIT_S)
                continue
            if sender != server and (reader.joined is not None or sender[0] != init_port[0]):
                continue  # not from rcssserver's port for this player
            silent_s = 0.0
            for item in reader.read(data.decode("latin-1")):
                if isinstance(item, Joined):
                    server = sender
                    if item.side != SIDE_OF_TEAM[agent.team]:
                        send("(bye)")
                        raise PlayerExit(EXIT_START_FAILED, f"{where} seated the {agent.team} on side {item.side}: "
                                                            f"it seats the team that joins first on the left, and "
                                                            f"the keepers must be on the left: start them first")
                    continue
                if isinstance(item, m.Error):
                    if reader.joined is None and item.code == CANNOT_RECONNECT and reconnect is not None:
                        if refused is None:
                            log.info("%s refused reconnect (%s); asking again every %g s for %g s", where,
                                     item.code, RECONNECT_RETRY_S, connect_timeout_s)
                        refused, retry_at = item.code, time.monotonic() + RECONNECT_RETRY_S
                    elif reader.joined is None:
                        joining = "init" if reconnect is None else "reconnect"
                        raise PlayerExit(EXIT_START_FAILED, f"{where} refused {joining}: {item.code}")
                    else:
                        log.warning("%s at cycle %d: %s", where, item.cycle, item.message,
                                    extra={KIND_ATTR: ("error", item.code)})
                    continue
                try:
                    command = agent.on_message(item)
                except (PolicyFileError, ValueError) as exc:
                    if not isinstance(item, m.InitOk):
                        raise
                    send("(bye)")
                    raise PlayerExit(EXIT_START_FAILED, str(exc)) from None
                if isinstance(item, m.InitOk):
                    log.info("joined as %s %d (%s mode, protocol version %d)", agent.team, agent.unum, agent.mode,
                             version)
                if isinstance(item, m.See) and item.cycle > 0:
                    sees += 1
                    late += item.cycle == thought
                text = "" if command is None else commands_text(command.commands)
                if isinstance(item, m.Think):
                    send(f"{text}(done)")  # a synchronous server waits for it, whether or not we act
                    thought = item.cycle
                elif text:
                    send(text)
    finally:
        if sees:
            log.info("%d of its %d sees came after their cycle's (think), taken in a cycle later", late, sees)
        sock.close()
        repeat_limit.flush()
        read_repeat_limit.flush()
