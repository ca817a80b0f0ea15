"""The player agent without sockets: decoded protocol messages in, one ``command`` per cycle out.

``PlayerAgent`` is what a ``keepaway player`` process runs between its socket loop (``agents/cli.py``)
and the decision kernels, and what the embedded mode drives directly (docs/design.md,
"Processes and sockets"). Per message (docs/protocol.md §6, §9):

* ``init_ok`` sets up the world model from the server's parameters, landmarks and arena config;
* ``sense_body`` / ``see`` / ``fullstate`` update the world model;
* ``hear`` from the referee ``training Keepaway 1`` is an episode boundary (docs/players.md §2
  step 1): the Pass learner ends its episode (only if it decided in it, so several boundaries in a row,
  as a paused server delivers them, are harmless), the coach's advice takes effect (so an episode never
  changes policy midway), the world model forgets the objects and the decision memory is cleared;
* ``hear`` from the coach is advice (docs/advice.md), kept for the next episode boundary (or the
  kick-off, the referee's first ``play_on``) and applied there in the order policy switch, ``pass_load``,
  ``pass_mode``, ``seed``; report requests are answered at once;
* the decision runs on ``think`` in synchronous mode, and on the cycle's first percept burst in
  real-time mode (``sense_body``, or the ``fullstate`` that follows it when exact percepts are used).

A decision is one call of ``keeper_decide`` / ``taker_decide`` on a batch of one, converted to the
atomic commands ``[main, turn_neck]``; the world model is told what was sent so it predicts the next
cycle. One kernel call (``agents.think.think``) hears, decides and writes the command's frame. The
per-cycle arrays are allocated once, at ``init_ok``.

With ``--pass learned`` the keeper's Pass decisions go to a :class:`PassLearner` (docs/players.md
§6.3: ``start``/``step``/``end``): by default an SMDP Sarsa learner
(:func:`sarsa_pass_factory`) starting from the policy file's Pass weights (keeper k's own
``pass_keeper<k>_*`` arrays when the file has them, else the plain ones), or from zeros without one, in
greedy mode (the frozen policy of evaluations).

The coach's advice (``hear`` with sender ``"coach"``; docs/advice.md) is decoded into the messages of
``protocol.advice`` and dispatched on their type:

* ``PolicyAdvice``: new GO:L parameters, and a switch of the keeper's Pass / GetOpen policy (keys of
  :data:`PASS_POLICIES` / :data:`GETOPEN_POLICIES`); a keeper switching to Pass ``learned`` without a
  learner gets a fresh Sarsa learner (zero weights, ``SarsaConfig()``, greedy);
* ``PassModeAdvice``: the Sarsa learner's mode;
* ``PassLoadAdvice``: a sparse Pass policy in chunks (``agents.pass_wire``); once complete, the keeper's
  learner becomes a Sarsa learner with those weights and collision table, greedy unless a
  ``PassModeAdvice`` says otherwise;
* ``SeedAdvice`` (takers too): every random stream of the agent restarts as if it had been started with
  that seed, and the world model and decision memory start afresh (fed again with the percepts of the
  current cycle), so its play from then on depends only on the seed, its policies and its percepts;
* ``ReportRequest``: every keeper answers (:meth:`PlayerAgent.pending_reports`, sent by the socket loop as
  ``report`` messages of at most ``REPORT_BYTES`` array bytes each): its Sarsa learner's SMDP transitions
  since the last such report (``PassTransitionsReport``), or its whole Pass policy in the sparse form of
  ``pass_load`` (``PassSnapshotReport``); a keeper without a Sarsa learner answers one empty report with
  ``learner`` false.

Decisions made outside (``outside``, for an environment that hands them to its caller: ``keepaway.env``):
a keeper may leave its Pass decisions (``"pass"``), its GetOpen decisions (``"getopen"``: a grid point)
or its whole body (``"body"``: the main command of every cycle) to the code that drives it. At such a
decision the message that calls for a command returns None and :attr:`PlayerAgent.awaiting` says what is
awaited; :meth:`PlayerAgent.act` takes the choice and returns the cycle's command, built as the agent's
own (the world model told, the say added). Everything else the agent does as always.

Bad advice is logged in one line and ignored; the agent keeps playing.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Collection
from dataclasses import dataclass, replace
from typing import Any, NamedTuple, Protocol

import numpy as np

from keepaway.agents.belief import forget_episode, new_decisions, new_memory
from keepaway.agents.command_wire import MAIN_COMMANDS, MAX_COMMAND_BYTES
from keepaway.agents.config import GETOPEN_EXTERNAL, GETOPEN_POLICIES, PASS_EXTERNAL, PASS_POLICIES, AgentConfig
from keepaway.agents.frames import NOT_TAKEN, SENDER, SIDE_CODES, TEXT_LENGTH, TEXT_START
from keepaway.agents.getopen import grid_size, grid_states, grid_values
from keepaway.agents.interception import decay_sums
from keepaway.agents.keeper import (
    GETOPEN_DECISION,
    NO_PASS_DECISION,
    PASS_DECISION_START,
    execute_getopen_action,
    execute_pass_action,
)
from keepaway.agents.movement import neck_to_ball
from keepaway.agents.pass_wire import REPORT_BYTES, chunked, pass_arrays_from_chunks, sparse_pass_chunks
from keepaway.agents.policy_file import (
    Policy,
    PolicyFileError,
    as_getopen_theta,
    getopen_theta_size,
    keeper_pass_arrays,
)
from keepaway.agents.sarsa import MODE_GREEDY, MODE_LEARN, MODE_NAMES, SarsaConfig, SarsaLearner
from keepaway.agents.say import BYTE_CODES, hear_bytes, hear_row, hear_text, new_talk
from keepaway.agents.state_vars import getopen_state_size, pass_state_size
from keepaway.agents.think import NOT_WRITTEN, finish_row, think
from keepaway.agents.worldmodel import WorldModel
from keepaway.core.jit import SteadyCall
from keepaway.core.objects import CMD_DASH
from keepaway.protocol import PROTOCOL_VERSION, ProtocolError
from keepaway.protocol import messages as m
from keepaway.protocol.advice import (
    REPORTED,
    PassLoadAdvice,
    PassModeAdvice,
    PassSnapshotReport,
    PassTransitionsReport,
    PolicyAdvice,
    ReportRequest,
    SeedAdvice,
    advice_kind,
)
from keepaway.protocol.messages import MAX_NOTE_NUMBERS, decode_from_player
from keepaway.protocol.params import ServerParams

log = logging.getLogger("keepaway.player")

TEAMS = ("keepers", "takers")
TIMING_MODES = ("sync", "realtime")
# Referee messages (docs/players.md §2 step 1; docs/protocol.md §6, "hear").
EPISODE_MESSAGE = "training Keepaway 1"
KICK_OFF_MESSAGE = "play_on"
LEARNED = "learned"  # the Pass policy name of the external learner
TEAMMATE = "our"  # the sender of a teammate's say (docs/protocol.md §6, "hear"), the only one taken in
# Arena size when init_ok's config does not give it (docs/players.md §1: 3 keepers vs 2 takers).
DEFAULT_KEEPERS = 3
DEFAULT_TAKERS = 2
# The decisions a keeper can leave to its caller (module docstring, "Decisions made outside").
OUTSIDE_PASS = "pass"  # action: 0 HoldBall, k >= 1 PassBall to the k-th nearest teammate
OUTSIDE_GETOPEN = "getopen"  # action: a grid point, 0 .. grid size - 1 (agents.getopen.grid_point)
OUTSIDE_BODY = "body"  # action: (main command code, arg1, arg2), CMD_DASH / CMD_TURN / CMD_KICK
OUTSIDE_DECISIONS = (OUTSIDE_PASS, OUTSIDE_GETOPEN, OUTSIDE_BODY)


class Awaiting(NamedTuple):
    """A decision a keeper waits for (:meth:`PlayerAgent.act`): one of :data:`OUTSIDE_DECISIONS`, in
    ``cycle``."""

    decision: str
    cycle: int


class Taken(NamedTuple):
    """What :meth:`PlayerAgent.take_frame` did with a frame: whether it took it, and if it did, the frame of
    the command to send (None if the frame calls for none): the bytes of ``encode`` of the ``m.Command``
    that :meth:`PlayerAgent.on_message` returns for the decoded message."""

    taken: bool
    command: bytes | None


_NOT_TAKEN = Taken(False, None)
_TAKEN = Taken(True, None)  # most frames call for no command; a NamedTuple costs 0.8 us to make


class PassLearner(Protocol):
    """A keeper's Pass decision maker (docs/players.md §6.3). ``state`` is the Pass state vector
    (4K + 2T - 3 floats); it is the agent's reused array, so copy it to keep it. Actions: 0 HoldBall,
    k >= 1 PassBall to the k-th nearest teammate. Rewards are in cycles."""

    def start(self, state: np.ndarray) -> int: ...

    def step(self, reward: float, state: np.ndarray) -> int: ...

    def end(self, reward: float) -> None: ...


PassLearnerFactory = Callable[[np.random.SeedSequence, int], PassLearner]
"""Builds a keeper's learner once its uniform number is known, from its own seed sequence and that
number."""


def sarsa_config(policy: Policy) -> SarsaConfig:
    """The tile-coding configuration a policy file's Pass weights were learned with (its header's
    ``config.sarsa``; the defaults of docs/players.md §6.3 when absent)."""
    settings = policy.config.get("sarsa", {})
    try:
        return SarsaConfig(**settings)
    except (TypeError, ValueError) as exc:
        raise PolicyFileError(f"{policy.path}: bad config.sarsa: {exc}") from None


def learner_seed(seq: np.random.SeedSequence) -> int:
    """The exploration seed of a Sarsa learner built from a keeper's learner seed sequence (the first
    child of its own, :meth:`PlayerAgent.learner_seed_sequence`): the sequence's first word."""
    return int(seq.generate_state(1, np.uint64)[0])


def sarsa_learner(seq: np.random.SeedSequence, n_keepers: int, n_takers: int, config: SarsaConfig, mode: int,
                  arrays: dict[str, np.ndarray] | None = None) -> SarsaLearner:
    """A keeper's SMDP Sarsa learner seeded from ``seq`` (:func:`learner_seed`), in ``mode``, loaded with
    ``arrays`` (``agents.sarsa.policy_arrays`` form) or from zero weights."""
    learner = SarsaLearner(n_keepers, n_takers, config, learner_seed(seq), mode)
    if arrays is not None:
        learner.load(arrays)
    return learner


def sarsa_pass_factory(
    policy: Policy | None,
    mode: int = MODE_GREEDY,
    config: SarsaConfig | None = None,
    n_keepers: int = DEFAULT_KEEPERS,
    n_takers: int = DEFAULT_TAKERS,
) -> PassLearnerFactory:
    """The ``--pass learned`` learner of a player process: an SMDP Sarsa learner
    (docs/players.md §6.3) in ``mode`` starting from the policy file's Pass weights for its keeper (its
    own ``pass_keeper<k>_*`` arrays, else the plain ones; the file's sizes and ``config.sarsa``), or
    without a file from zero weights for ``n_keepers`` vs ``n_takers`` with ``config`` (default
    ``SarsaConfig()``). Its exploration stream is seeded by :func:`learner_seed`. Raises
    :class:`PolicyFileError` at once (before any game) when the file has no usable Pass weights for some
    keeper."""
    if policy is None:
        config = config or SarsaConfig()
        return lambda seq, unum: sarsa_learner(seq, n_keepers, n_takers, config, mode)
    if policy.pass_weights is None:
        raise PolicyFileError(f"{policy.path}: this policy file has no Pass weights")
    config = sarsa_config(policy)
    keepers = [keeper_pass_arrays(policy.pass_arrays, k) for k in range(1, policy.n_keepers + 1)]
    probe = SarsaLearner(policy.n_keepers, policy.n_takers, config, 0, mode)
    for k, arrays in enumerate(keepers, start=1):
        try:
            probe.load(arrays)
        except (KeyError, ValueError) as exc:
            raise PolicyFileError(f"{policy.path}: keeper {k}'s Pass weights do not fit the Sarsa learner: "
                                  f"{exc}") from None
    return lambda seq, unum: sarsa_learner(seq, policy.n_keepers, policy.n_takers, config, mode, keepers[unum - 1])


def greedy_pass_factory(policy: Policy | None) -> PassLearnerFactory:
    """The policy file's SMDP Sarsa weights, frozen (greedy actions, no updates:
    docs/players.md §6.3, evaluation); a file with Pass weights is required."""
    if policy is None:
        raise PolicyFileError("--pass learned needs a policy file with Pass weights (--policy FILE)")
    return sarsa_pass_factory(policy, MODE_GREEDY)


class _Fields:
    """A message seen as the read-only mapping the world model's ``on_*`` methods take (no copy)."""

    __slots__ = ("msg",)

    def __init__(self) -> None:
        self.msg: Any = None

    def __getitem__(self, name: str) -> Any:
        return getattr(self.msg, name)


def agent_seed_sequence(seed: int, side_code: int, unum: int) -> np.random.SeedSequence:
    """A player's own randomness, derived from the run seed, its side and its uniform number, so which
    process connects first does not matter (docs/advice.md §2, "seed"); every mode derives it here."""
    return np.random.SeedSequence([int(seed), side_code, unum])


@dataclass
class _Advice:
    """The coach's advice kept for the next episode boundary or kick-off (None: nothing advised)."""

    theta: np.ndarray | None = None  # GO:L parameters
    pass_policy: str | None = None  # a key of PASS_POLICIES
    getopen_policy: str | None = None  # a key of GETOPEN_POLICIES
    load: tuple[SarsaConfig, dict[str, np.ndarray]] | None = None  # a complete pass_load
    pass_mode: int | None = None  # MODE_*
    seed: int | None = None


class PlayerAgent:
    """One keeper or taker, driven by decoded protocol messages (module docstring).

    ``pass_policy`` and ``getopen_policy`` name keys of :data:`PASS_POLICIES` and
    :data:`GETOPEN_POLICIES` (keepers only); ``policy`` is a loaded policy file (GO:L parameters, Pass
    weights); ``seed`` with the side and uniform number seeds the agent's own random stream
    (``SeedSequence([seed, side, unum])``, side 0 = keepers), so every player of a run is reproducible;
    ``fullstate`` uses the exact ``fullstate`` percepts (the player must ask for them in ``init``).
    ``pass_learner`` replaces the ``--pass learned`` learner (default: :func:`sarsa_pass_factory` on
    ``policy``, greedy until the coach's ``pass_mode`` advice). ``outside`` names the keeper's decisions
    left to the caller (:data:`OUTSIDE_DECISIONS`; module docstring): they replace ``pass_policy`` and
    ``getopen_policy`` for those decisions, and ``"body"`` replaces both and comes alone.
    Raises :class:`PolicyFileError` when the policy cannot serve the chosen policies, ValueError for
    unknown names.
    """

    def __init__(
        self,
        team: str,
        pass_policy: str = "handcoded",
        getopen_policy: str = "handcoded",
        policy: Policy | None = None,
        seed: int = 0,
        fullstate: bool = False,
        pass_learner: PassLearnerFactory | None = None,
        config: AgentConfig | None = None,
        outside: Collection[str] = (),
    ) -> None:
        if team not in TEAMS:
            raise ValueError(f"team must be one of {TEAMS}, not {team!r}")
        if pass_policy not in PASS_POLICIES:
            raise ValueError(f"unknown Pass policy {pass_policy!r}; choose one of {list(PASS_POLICIES)}")
        if getopen_policy not in GETOPEN_POLICIES:
            raise ValueError(f"unknown GetOpen policy {getopen_policy!r}; choose one of {list(GETOPEN_POLICIES)}")
        if seed < 0:
            raise ValueError(f"seed must be >= 0, not {seed}")
        outside = frozenset(outside)
        if not outside <= set(OUTSIDE_DECISIONS):
            raise ValueError(f"decisions made outside must be among {OUTSIDE_DECISIONS}, not {sorted(outside)}")
        if outside and team != "keepers":
            raise ValueError("only keepers leave decisions to their caller")
        if OUTSIDE_BODY in outside and len(outside) > 1:
            raise ValueError(f"{OUTSIDE_BODY!r} leaves every decision outside: it comes alone")
        self.team = team
        self.is_keeper = team == "keepers"
        self.policy = policy
        self.seed = seed
        self.fullstate = fullstate
        self.config = replace(config or AgentConfig(),
                              pass_policy=PASS_EXTERNAL if OUTSIDE_PASS in outside else PASS_POLICIES[pass_policy],
                              getopen_policy=(GETOPEN_EXTERNAL if OUTSIDE_GETOPEN in outside
                                              else GETOPEN_POLICIES[getopen_policy]))
        self.outside = outside
        self.awaiting: Awaiting | None = None
        external = self.is_keeper and pass_policy == LEARNED and OUTSIDE_PASS not in outside
        if pass_learner is not None and not external:
            raise ValueError("a Pass learner is only used by keepers with the 'learned' Pass policy")
        self._external = external
        self._learner_factory = pass_learner or (sarsa_pass_factory(policy) if external and policy else None)
        if self.is_keeper and getopen_policy == LEARNED and policy is not None and policy.getopen_theta is None:
            raise PolicyFileError(f"{policy.path}: this policy file has no GetOpen weights (getopen_theta)")
        self.learner: PassLearner | None = None
        self.side: str | None = None
        self.unum: int | None = None
        self.mode: str | None = None
        self.episodes = 0  # episode boundaries heard
        self._pending = _Advice()
        self._load_parts: list[PassLoadAdvice] = []  # pass_load chunks collected so far
        self._reports: list[m.Report] = []
        self._reported = 0  # sequence number of the next transition to report
        self._started = False
        self._fields = _Fields()
        # the decision kernels of every cycle, called without numba's typing of their arguments at each call
        self._hear_row = SteadyCall(hear_row)
        self._hear_bytes = SteadyCall(hear_bytes)
        self._think = SteadyCall(think)
        self._finish_row = SteadyCall(finish_row)
        self._command_buf = np.zeros(MAX_COMMAND_BYTES, np.uint8)  # the command frame a think writes
        self._note = np.zeros(MAX_NOTE_NUMBERS)  # its GetOpen note
        # What the world model was fed in the cycle of the last percept (percepts and own commands), to
        # feed a fresh world model again at a seed advice.
        self._cycle = -1
        self._cycle_log: list[Any] = []
        self._decide_on: type | None = None
        self._handlers: dict[type, Callable[[Any], bytes | None]] = {
            m.InitOk: self._on_init_ok, m.SenseBody: self._on_sense_body, m.See: self._on_see,
            m.Fullstate: self._on_fullstate, m.Hear: self._on_hear, m.Think: self._on_think,
        }
        # take_frame's handlers of (cycle, frame), by the kind agents.frames.decode_frame read
        # (agents.frames.FRAME_TYPES: see, sense_body, hear, think); the world model took the percepts
        self._frame_handlers: tuple[Callable[[int, bytes], bytes | None], ...] = (
            lambda cycle, data: self._record(cycle, data),
            lambda cycle, data: self._sensed_body(cycle, data),
            self._heard_frame,
            lambda cycle, data: self._thought(cycle),
        )
        self._advice_handlers: dict[type, Callable[[Any, int], None]] = {
            SeedAdvice: self._on_seed_advice, PassModeAdvice: self._on_pass_mode_advice,
            ReportRequest: self._on_report_request, PolicyAdvice: self._on_policy_advice,
            PassLoadAdvice: self._on_pass_load_advice,
        }

    @property
    def ready(self) -> bool:
        """Whether ``init_ok`` has been received."""
        return self.side is not None

    def on_message(self, msg: m.Message) -> m.Command | None:
        """Take one decoded server message; return the command to send, if this message calls for one.
        ``error`` and ``shutdown`` are the transport's business and return None, as does anything
        before ``init_ok``."""
        frame = self.message_frame(msg)
        return None if frame is None else decode_from_player(frame)

    def message_frame(self, msg: m.Message) -> bytes | None:
        """:meth:`on_message`, with the command as the frame to send (``agents.command_wire``): what a
        caller that sends it takes, so the command is not decoded only to be encoded again."""
        handler = self._handlers.get(type(msg))
        if handler is None or (not self.ready and type(msg) is not m.InitOk):
            return None
        return handler(msg)

    # -- setup -------------------------------------------------------------------------------------
    def _on_init_ok(self, msg: m.InitOk) -> None:
        """Build the world model and the per-cycle arrays. Raises ValueError or PolicyFileError (one
        line) when the arena does not fit this agent."""
        config = msg.config
        n_keepers = config.get("keepers", DEFAULT_KEEPERS)
        n_takers = config.get("takers", DEFAULT_TAKERS)
        mode = config.get("mode", "sync")
        if mode not in TIMING_MODES:
            raise ValueError(f"the server's timing mode {mode!r} is not one of {TIMING_MODES}")
        if type(n_keepers) is not int or type(n_takers) is not int:
            raise ValueError(f"the server's team sizes {n_keepers!r} and {n_takers!r} are not integers")
        notes = config.get("getopen_notes", "none")
        if notes not in m.GETOPEN_NOTE_MODES:
            raise ValueError(f"the server's getopen_notes {notes!r} is not one of {m.GETOPEN_NOTE_MODES}")
        self.getopen_notes = notes if self.is_keeper else "none"
        policy = self.policy
        if self.is_keeper and policy is not None and (policy.n_keepers, policy.n_takers) != (n_keepers, n_takers):
            raise PolicyFileError(f"{policy.path}: the policy is for {policy.n_keepers} keepers and "
                                  f"{policy.n_takers} takers, the server plays {n_keepers} vs {n_takers}")
        params = ServerParams.from_dict(msg.params)
        self._world_args = (params, msg.side, msg.unum, n_keepers, n_takers, msg.landmarks["flags"],
                            self.config)
        self.wm = WorldModel(*self._world_args)
        self.talk = new_talk(1)
        self.kp = self.wm.kp
        self.n_keepers, self.n_takers, self.mode = n_keepers, n_takers, mode
        self.side, self.unum = msg.side, msg.unum
        self.cfg = self.config.kernel()
        self.decay_sums = decay_sums(self.kp, self.cfg)  # the decisions' travel table, one per game
        self.memory = self._new_memory()
        self.theta = np.zeros(getopen_theta_size(n_keepers, n_takers))
        if self.is_keeper and policy is not None and policy.getopen_theta is not None:
            self.theta[:] = policy.getopen_net  # the file's input scaling folded in
        self.decisions = new_decisions(1, pass_state_size(n_keepers, n_takers))  # what the decision kernels write
        self.pass_state = self.decisions.pass_state[0]  # the Pass learner's input
        self._grid_values = np.zeros((grid_size(self.cfg), 3))  # the rows of a GetOpen note's values
        self._noted_time = -1  # the getopen_time of the last GetOpen note sent
        factory = self._learner_factory
        if factory is None and self._external:
            factory = sarsa_pass_factory(None, n_keepers=n_keepers, n_takers=n_takers)
        if factory is not None:
            self._set_learner(factory(self.learner_seed_sequence(), msg.unum))
        self._started = msg.play_mode == KICK_OFF_MESSAGE
        if mode == "sync":
            self._decide_on = m.Think
        else:
            self._decide_on = m.Fullstate if self.fullstate else m.SenseBody
        return None

    def seed_sequence(self) -> np.random.SeedSequence:
        """This agent's own randomness under its current seed (:func:`agent_seed_sequence`)."""
        return agent_seed_sequence(self.seed, SIDE_CODES[self.side], self.unum)

    def learner_seed_sequence(self) -> np.random.SeedSequence:
        """The Pass learner's randomness: the first child of :meth:`seed_sequence`."""
        return self.seed_sequence().spawn(1)[0]

    def _new_memory(self) -> Any:
        """A fresh decision memory whose random stream is the first word of :meth:`seed_sequence`."""
        return new_memory(1, self.seed_sequence().generate_state(1, np.uint64))

    def _set_learner(self, learner: PassLearner) -> None:
        """A new Pass learner: its transition log starts at sequence number 0."""
        self.learner = learner
        self._reported = 0

    # -- percepts ----------------------------------------------------------------------------------
    def _view(self, msg: m.Message) -> _Fields:
        self._fields.msg = msg
        return self._fields

    def _record(self, cycle: int, item: Any = None) -> None:
        """Log what the world model was fed in ``cycle`` (a percept: a message, or the bytes of a frame taken
        straight; or own commands as a tuple); any message of a later cycle (``item`` None: a hear) starts a
        new log."""
        if cycle != self._cycle:
            self._cycle, self._cycle_log = cycle, []
        if item is not None:
            self._cycle_log.append(item)

    def _on_sense_body(self, msg: m.SenseBody) -> bytes | None:
        self.wm.on_sense_body(self._view(msg))
        return self._sensed_body(msg.cycle, msg)

    def _sensed_body(self, cycle: int, item: Any) -> bytes | None:
        """A sense_body the world model took, logged as ``item``; the decision, if it runs on sense_body."""
        self._record(cycle, item)
        return self._decide(cycle) if self._decide_on is m.SenseBody else None

    def _on_see(self, msg: m.See) -> None:
        self.wm.on_see(self._view(msg))
        self._record(msg.cycle, msg)

    def take_frame(self, data: bytes) -> Taken:
        """A frame from the server, taken as :meth:`on_message` takes the decoded message, straight from
        its bytes (``WorldModel.on_frame``, ``agents.frames``), if it is a see, sense_body, player's hear
        or think in the form the server sends them: returns ``Taken(True, command)``, with the frame of the
        command to send if the frame calls for one. ``Taken(False, None)``, with nothing done, for any other
        frame and before ``init_ok``: the caller decodes it (``protocol.messages.decode_for_player``) and
        hands it to :meth:`on_message`."""
        if self.side is None:  # not ready
            return _NOT_TAKEN
        kind, cycle = self.wm.on_frame(data)
        if kind == NOT_TAKEN:
            return _NOT_TAKEN
        command = self._frame_handlers[kind](cycle, data)
        return _TAKEN if command is None else Taken(True, command)

    def _on_fullstate(self, msg: m.Fullstate) -> bytes | None:
        if not self.fullstate:
            return None
        self.wm.on_fullstate(self._view(msg))
        self._record(msg.cycle, msg)
        return self._decide(msg.cycle) if self._decide_on is m.Fullstate else None

    def _on_think(self, msg: m.Think) -> bytes | None:
        return self._thought(msg.cycle)

    def _thought(self, cycle: int) -> bytes | None:
        """The decision, if it runs on think."""
        return self._decide(cycle) if self._decide_on is m.Think else None

    def _on_hear(self, msg: m.Hear) -> None:
        if msg.sender in m.PLAYER_HEAR_SENDERS:
            if self._heard_player(msg.cycle, msg.sender):
                hear_text(self.talk, 0, msg.message)
            return
        self._record(msg.cycle)  # a paused server's bare hears belong to a cycle without percepts yet
        if msg.sender == "referee":
            if msg.message == EPISODE_MESSAGE:
                self._episode_boundary(msg.cycle)
            elif msg.message == KICK_OFF_MESSAGE and not self._started:
                self._started = True
                self._apply_advice()
        else:
            self._on_advice(msg.message, msg.cycle)

    def _heard_player(self, cycle: int, sender: str) -> bool:
        """A player's say (``self``, ``our`` or ``opp``) heard: whether its text is taken in, which only a
        teammate's is (at the decision, after this cycle's see)."""
        self._record(cycle)
        return sender == TEAMMATE

    def _heard_frame(self, cycle: int, data: bytes) -> None:
        """A player's hear read from its frame (``agents.frames``: an ASCII text at its place in the frame),
        its text's codes read there (``agents.say.hear_bytes``)."""
        values = self.wm.frame_values
        if self._heard_player(cycle, m.PLAYER_HEAR_SENDERS[int(values[SENDER])]):
            self._hear_bytes(self.talk, 0, data, int(values[TEXT_START]), int(values[TEXT_LENGTH]), BYTE_CODES)

    def _fresh_world_model(self) -> None:
        """A world model that knows nothing, fed again with this cycle's percepts and own commands (those
        before the current message), so it depends on them alone."""
        self.wm = WorldModel(*self._world_args)
        feed = {m.SenseBody: self.wm.on_sense_body, m.See: self.wm.on_see, m.Fullstate: self.wm.on_fullstate}
        for item in self._cycle_log:
            if type(item) is tuple:
                self.wm.on_own_commands(*item)
            elif type(item) is bytes:  # a see or sense_body taken straight from its frame
                self.wm.on_frame(item)
            else:
                feed[type(item)](self._view(item))

    # -- episodes and advice -----------------------------------------------------------------------
    def _episode_boundary(self, cycle: int) -> None:
        """End the learner's episode with reward now - t_last (docs/players.md §2 step 1; only if
        it decided in this episode), take up the advice, forget the objects, clear the decision memory."""
        t_last = int(self.memory.t_last[0])
        if self.learner is not None and t_last >= 0:
            self.learner.end(float(cycle - t_last))
        self._apply_advice()
        self.wm.forget()
        forget_episode(self.memory, 0)
        self.episodes += 1

    def _apply_advice(self) -> None:
        """The advice kept since the last boundary, in the order of docs/advice.md."""
        advice, self._pending = self._pending, _Advice()
        if advice.theta is not None:
            self.theta[:] = advice.theta
        if advice.pass_policy is not None or advice.getopen_policy is not None:
            self._switch_policies(advice.pass_policy, advice.getopen_policy)
        if advice.load is not None:
            config, arrays = advice.load
            self._set_learner(sarsa_learner(self.learner_seed_sequence(), self.n_keepers, self.n_takers, config,
                                            MODE_GREEDY, arrays))
        if advice.pass_mode is not None:
            self._set_pass_mode(advice.pass_mode)
        if advice.seed is not None:
            self._reseed(advice.seed)

    def _switch_policies(self, pass_policy: str | None, getopen_policy: str | None) -> None:
        """The policy advice's switch; Pass ``learned`` without a learner brings a fresh Sarsa learner."""
        changes = {}
        if pass_policy is not None:
            changes["pass_policy"] = PASS_POLICIES[pass_policy]
        if getopen_policy is not None:
            changes["getopen_policy"] = GETOPEN_POLICIES[getopen_policy]
        self.config = replace(self.config, **changes)
        self.cfg = self.config.kernel()
        if pass_policy == LEARNED and self.learner is None:
            factory = sarsa_pass_factory(None, n_keepers=self.n_keepers, n_takers=self.n_takers)
            self._set_learner(factory(self.learner_seed_sequence(), self.unum))

    def _set_pass_mode(self, mode: int) -> None:
        """A keeper without a learner has no mode to set; another learner than Sarsa has none we know."""
        if isinstance(self.learner, SarsaLearner):
            self.learner.mode = mode
        elif self.learner is not None:
            log.warning("ignored the coach's pass_mode advice: the Pass learner is not a Sarsa learner")

    def _reseed(self, seed: int) -> None:
        """Restart every random stream as if the agent had been started with ``seed``, with a fresh
        decision memory and world model, nothing heard, and this cycle as its cycle 0 for talking
        (docs/advice.md §2, "seed"): teammates' says of the old episode may arrive as bare hears while the
        server is paused, before this advice, and a fresh player says nothing in its first cycle."""
        self.seed = seed
        self.memory = self._new_memory()
        self.talk = new_talk(1, start=self._cycle)
        self._fresh_world_model()
        if isinstance(self.learner, SarsaLearner):
            self.learner.reseed(learner_seed(self.learner_seed_sequence()))
        elif self.learner is not None:
            log.warning("the coach's seed advice cannot reseed the Pass learner: it is not a Sarsa learner")

    def _on_advice(self, payload: Any, cycle: int) -> None:
        """Decode the coach's advice (``protocol.advice``) and dispatch it on its type: kept for the next
        episode boundary (or kick-off), or a report request queued at once. A payload of no known kind is
        not for this agent, nor is any advice but seed for a taker. Bad advice is logged in one line and
        ignored."""
        cls = advice_kind(payload)
        if cls is None or (not self.is_keeper and cls is not SeedAdvice):
            return
        try:
            advice = cls.from_wire(payload)
        except ProtocolError as exc:
            log.warning("ignored the coach's %s advice: %s: %s", cls.TYPE, exc.code, exc.message)
            return
        self._advice_handlers[cls](advice, cycle)

    def _on_seed_advice(self, advice: SeedAdvice, cycle: int) -> None:
        self._pending.seed = advice.seed

    def _on_pass_mode_advice(self, advice: PassModeAdvice, cycle: int) -> None:
        self._pending.pass_mode = MODE_NAMES[advice.mode]

    def _on_policy_advice(self, advice: PolicyAdvice, cycle: int) -> None:
        """GO:L parameters and policy names, all kept or, if the parameters do not fit this arena's net,
        none."""
        if advice.getopen_theta is not None:
            try:
                self._pending.theta = as_getopen_theta(advice.getopen_theta, self.theta.size)
            except ValueError as exc:
                log.warning("ignored the coach's %s advice: %s", advice.TYPE, exc)
                return
        if advice.pass_policy is not None:
            self._pending.pass_policy = advice.pass_policy
        if advice.getopen_policy is not None:
            self._pending.getopen_policy = advice.getopen_policy

    def _on_pass_load_advice(self, advice: PassLoadAdvice, cycle: int) -> None:
        """Collect the chunks of a sparse Pass policy (chunk 0 starts over); keep it once complete."""
        try:
            if advice.chunk == 0:
                self._load_parts = []
            elif not self._load_parts:
                raise ValueError(f"chunk {advice.chunk} of {advice.chunks} came without chunk 0")
            self._load_parts.append(advice)
            if len(self._load_parts) < self._load_parts[0].chunks:
                return
            parts, self._load_parts = self._load_parts, []
            self._pending.load = pass_arrays_from_chunks(parts)
        except ValueError as exc:
            log.warning("ignored the coach's %s advice: %s", advice.TYPE, exc)

    def _on_report_request(self, request: ReportRequest, cycle: int) -> None:
        """Queue the requested report at once (a report changes nothing in the game)."""
        report = REPORTED[request.what]
        if not isinstance(self.learner, SarsaLearner):
            reports = [report(learner=False, episode=self.episodes, chunk=0, chunks=1, first=0, count=0)]
        elif report is PassTransitionsReport:
            reports = self._transition_reports()
        else:
            reports = sparse_pass_chunks(self.learner.save(), self.learner.config, PassSnapshotReport,
                                         episode=self.episodes, learner=True)
        self._reports += [m.Report(cycle=cycle, payload=r.to_wire()) for r in reports]

    def _transition_reports(self) -> list[PassTransitionsReport]:
        """The learner's SMDP transitions since the last transitions report (``first`` = sequence number;
        ``dropped``: transitions lost from its ring buffer since then)."""
        logged = self.learner.transitions(self._reported)
        sequence = logged.pop("sequence")
        first = int(sequence[0]) if len(sequence) else int(self.learner.memory.log_count[0])
        head = {"learner": True, "episode": self.episodes, "dropped": first - self._reported,
                "n_vars": self.pass_state.size}
        self._reported = first + len(sequence)
        return chunked(PassTransitionsReport, head, logged, len(sequence), first)

    def pending_reports(self) -> list[m.Report]:
        """The ``report`` messages queued for the coach since the last call (the socket loop sends them)."""
        reports, self._reports = self._reports, []
        return reports

    # -- deciding ----------------------------------------------------------------------------------
    def _decide(self, cycle: int) -> bytes | None:
        """Run the decision kernel for this cycle and turn its output into the command's frame; None when
        the decision is left outside (:attr:`awaiting`). The think kernel (``agents.think``) writes the
        frame itself unless a note is asked for or a decision point is left to Python."""
        wm = self.wm
        if OUTSIDE_BODY in self.outside:
            if not self.fullstate:  # the C++ ignores what it hears while it has the full state
                self._hear_row(0, wm.state, self.n_keepers, self.cfg, self.talk)
            wm.belief()
            self.awaiting = Awaiting(OUTSIDE_BODY, cycle)
            return None
        decision, n = self._think(cycle, not self.fullstate, wm.state, self.talk, wm.belief_rows, self.memory,
                                  self.theta, self.decay_sums, self.kp, self.cfg, self.is_keeper, self.decisions,
                                  self.learner is None and OUTSIDE_PASS not in self.outside,
                                  self.getopen_notes == "none", self._command_buf, self._note)
        if n != NOT_WRITTEN:
            return self._sent(cycle, n)
        if decision == GETOPEN_DECISION:
            self.awaiting = Awaiting(OUTSIDE_GETOPEN, cycle)
            return None
        if decision != NO_PASS_DECISION and OUTSIDE_PASS in self.outside:
            self.awaiting = Awaiting(OUTSIDE_PASS, cycle)
            return None
        # the learner plays only while the Pass policy is the learned one (docs/advice.md: a keeper
        # switched to another policy keeps its learner for a switch back; that policy has already acted)
        if decision != NO_PASS_DECISION and self.learner is not None and self.cfg.pass_policy == PASS_EXTERNAL:
            self._ask_learner(wm.belief_rows, decision)
        return self._command(cycle)

    def act(self, action: Any) -> m.Command:
        """The decision :attr:`awaiting` waits for, made: a Pass action (0 HoldBall, k PassBall to the k-th
        nearest teammate), a grid point, or a main command ``(code, arg1, arg2)`` (module docstring), with
        the neck turned to the ball as the hand-coded keepers do). Returns the cycle's command. ValueError
        (one line) when nothing is awaited or the action is not one."""
        return decode_from_player(self.act_frame(action))

    def act_frame(self, action: Any) -> bytes:
        """:meth:`act`, with the command as the frame to send (as :meth:`message_frame`)."""
        awaiting = self.awaiting
        if awaiting is None:
            raise ValueError("no decision is awaited")
        bel = self.wm.belief()
        out = self.decisions
        if awaiting.decision == OUTSIDE_BODY:
            code, a1, a2 = action
            if int(code) not in MAIN_COMMANDS:
                raise ValueError(f"the main command code {code} is not one of {sorted(MAIN_COMMANDS)}")
            out.main[0], out.arg1[0], out.arg2[0] = int(code), float(a1), float(a2)
            out.neck[0] = neck_to_ball(bel, 0, int(code), float(a1), self.kp)
        else:
            count = self.n_keepers if awaiting.decision == OUTSIDE_PASS else grid_size(self.cfg)
            if not 0 <= int(action) < count:
                raise ValueError(f"{awaiting.decision} action {action} is not in 0..{count - 1}")
            if awaiting.decision == OUTSIDE_PASS:
                execute_pass_action(bel, 0, self.memory, int(action), self.kp, self.cfg, out)
            else:
                execute_getopen_action(bel, 0, self.memory, int(action), self.kp, self.cfg, out)
        self.awaiting = None
        return self._command(awaiting.cycle)

    def _getopen_note(self) -> tuple[float, ...]:
        """The GetOpen note this cycle's command carries (``protocol.messages.getopen_note``): none unless
        the server asks for notes and this keeper's GetOpen moved it this cycle; the values are what its
        policy rates the grid points with, from the belief it decided on."""
        time = int(self.memory.getopen_time[0])
        if self.getopen_notes == "none" or time == self._noted_time or time < 0:
            return ()
        self._noted_time = time
        note = tuple(float(v) for v in self.memory.getopen_point[0])
        if self.getopen_notes == "values":
            n = grid_values(self.wm.belief(), 0, self.theta, self.decay_sums, self.kp, self.cfg, self._grid_values)
            note += tuple(self._grid_values[:n].ravel().tolist())
        return note

    def _command(self, cycle: int) -> bytes:
        """This cycle's decision (the output arrays) as its command frame (``agents.think.finish_row``: the
        bytes of ``encode(m.Command(...))`` with the main command, the neck's turn, the say and the note);
        the world model is told."""
        note = self._getopen_note()
        if note:
            self._note[:len(note)] = note
        n = self._finish_row(cycle, self.wm.state, self.talk, self.n_keepers, self.kp, self.cfg, self.decisions,
                             self._command_buf, self._note, len(note))
        return self._sent(cycle, n)

    def _sent(self, cycle: int, n: int) -> bytes:
        """The command frame of ``n`` bytes just written; its commands logged for a seed advice's replay."""
        out = self.decisions
        self._record(cycle, (int(out.main[0]), float(out.arg1[0]), float(out.arg2[0]), float(out.neck[0])))
        return self._command_buf[:n].tobytes()

    def _ask_learner(self, bel: Any, decision: int) -> None:
        """A Pass decision point with an external learner (agents/keeper.py docstring): start or step
        with reward = now - t_last, then execute its action."""
        if decision == PASS_DECISION_START:
            action = self.learner.start(self.pass_state)
        else:
            action = self.learner.step(float(bel.time[0] - self.memory.t_last[0]), self.pass_state)
        if not 0 <= action < self.n_keepers:
            raise ValueError(f"the Pass learner chose action {action}; actions are 0..{self.n_keepers - 1}")
        execute_pass_action(bel, 0, self.memory, int(action), self.kp, self.cfg, self.decisions)


def compile_kernels(percepts: bool = True, decisions: bool = True) -> None:
    """Run every kernel a player uses once, on a synthetic arena, so numba compiles them (or loads them
    from its cache) before a server waits for this player's answers. In two halves, so that two processes
    compile them side by side (runner.kernels; docs/design.md, "Compiled kernels", has the measurements):
    ``percepts``, the percepts taken (decoded and from their frames), the hears and the Sarsa learner's
    kernels; ``decisions``, the think (from a ``think`` decoded and from its frame, on a model that may
    have seen nothing: numba compiles for the arguments' types, not their values) and the decisions that
    Python calls outside it."""
    from keepaway.protocol.codec import encode
    from keepaway.protocol.landmarks import to_wire
    from keepaway.protocol.params import parameter_set

    params = parameter_set("classic")
    init = dict(version=PROTOCOL_VERSION, cycle=0, play_mode="play_on", params=params.to_dict(), landmarks=to_wire(),
                config={"mode": "sync", "keepers": DEFAULT_KEEPERS, "takers": DEFAULT_TAKERS})
    see = m.See(cycle=0, flags=((0, 10.0, 0, None, None), (1, 30.0, 40, 0.1, 0.2)), lines=(),
                ball=(2.0, 10, 0.1, 1.0),
                players=(("l", 2, 5.0, -20, 0.0, 0.0, 10, 10), (None, None, 30.0, 40, None, None, None, None)))
    body = m.SenseBody(cycle=0, view_mode=("high", "normal"), stamina=(4000.0, 1.0, -1.0), speed=(0.0, 0),
                       head_angle=0, counts={}, collision=())
    heard = m.Hear(cycle=0, sender="our", direction=0, unum=2, message="1aaaa18aa1")
    think_frame = encode(m.Think(cycle=0))
    for team, side in (("keepers", "l"), ("takers", "r")):
        agent = PlayerAgent(team)
        agent.on_message(m.InitOk(side=side, unum=1, team=team, **init))
        if percepts:
            for msg in (body, see, heard, m.Hear(cycle=0, sender="referee", message=EPISODE_MESSAGE)):
                agent.on_message(msg)
            for msg in (see, body, heard):
                agent.take_frame(encode(msg))
            agent.wm.on_own_commands(CMD_DASH, 0.0, 0.0)  # as a seed advice's replay feeds them (_fresh_world_model)
        if not decisions:
            continue
        agent.on_message(m.Think(cycle=0))
        agent.take_frame(think_frame)
        if agent.is_keeper:
            execute_pass_action(agent.wm.belief(), 0, agent.memory, 0, agent.kp, agent.cfg, agent.decisions)
            grid_values(agent.wm.belief(), 0, agent.theta, agent.decay_sums, agent.kp, agent.cfg,
                        agent._grid_values)  # notes
            # the decisions left outside (act, keepaway.env): GetOpen's grid observation and action, and
            # the neck of a low-level command
            grid_states(agent.wm.belief(), 0, agent.decay_sums, agent.kp, agent.cfg,
                        np.zeros((grid_size(agent.cfg), getopen_state_size(DEFAULT_KEEPERS, DEFAULT_TAKERS))))
            execute_getopen_action(agent.wm.belief(), 0, agent.memory, 0, agent.kp, agent.cfg, agent.decisions)
            neck_to_ball(agent.wm.belief(), 0, CMD_DASH, 0.0, agent.kp)
    if decisions:
        # a decision left outside: heard from Python, its command sent by agents.think.finish_row
        agent = PlayerAgent("keepers", outside=(OUTSIDE_BODY,))
        agent.on_message(m.InitOk(side="l", unum=1, team="keepers", **init))
        for msg in (body, see, heard):
            agent.take_frame(encode(msg))
        agent.take_frame(think_frame)
        agent.act_frame((CMD_DASH, 0.0, 0.0))
    if percepts:
        # the Sarsa learner's kernels: a keeper may become a learner at any episode boundary (docs/advice.md)
        learner = SarsaLearner(DEFAULT_KEEPERS, DEFAULT_TAKERS, SarsaConfig(table_size=1 << 16), 0, MODE_LEARN)
        state = np.zeros(pass_state_size(DEFAULT_KEEPERS, DEFAULT_TAKERS))
        learner.start(state)
        learner.step(1.0, state)
        learner.end(1.0)


__all__ = [
    "Awaiting",
    "EPISODE_MESSAGE",
    "GETOPEN_POLICIES",
    "OUTSIDE_BODY",
    "OUTSIDE_DECISIONS",
    "OUTSIDE_GETOPEN",
    "OUTSIDE_PASS",
    "PASS_POLICIES",
    "REPORT_BYTES",
    "PassLearner",
    "PassLearnerFactory",
    "PlayerAgent",
    "Taken",
    "agent_seed_sequence",
    "compile_kernels",
    "greedy_pass_factory",
    "learner_seed",
    "sarsa_config",
    "sarsa_learner",
    "sarsa_pass_factory",
]
