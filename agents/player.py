"""The player agent without sockets: decoded protocol messages in, one ``command`` per cycle out.

``PlayerAgent`` is what a ``keepaway player`` process runs between its socket loop (``agents/cli.py``)
and the decision kernels, and what the embedded mode drives directly (spec `architecture.md`, Embedded
and batched execution). Per message (docs/protocol.md 6, 9):

* ``init_ok`` sets up the world model from the server's parameters, landmarks and arena config;
* ``sense_body`` / ``see`` / ``fullstate`` update the world model;
* ``hear`` from the referee ``training Keepaway 1`` is an episode boundary (spec `keepaway-agents.md` 1
  step 1): the world model forgets, the decision memory is cleared, the Pass learner ends its episode and
  GetOpen parameters advised by the coach take effect (so an episode never changes policy midway);
* the decision runs on ``think`` in synchronous mode, and on the cycle's first percept burst in
  real-time mode (``sense_body``, or the ``fullstate`` that follows it when exact percepts are used).

A decision is one call of ``keeper_decide`` / ``taker_decide`` on a batch of one, converted to the
atomic commands ``[main, turn_neck]``; the world model is told what was sent so it predicts the next
cycle. The per-cycle arrays are allocated once, at ``init_ok``.

With ``--pass learned`` the keeper's Pass decisions go to a :class:`PassLearner` (spec
`keepaway-agents.md` 5: ``start``/``step``/``end``): by default an SMDP Sarsa learner
(:func:`sarsa_pass_factory`) starting from the policy file's Pass weights, or from zeros without one, in
greedy mode (the frozen policy of evaluations). The coach switches it with the advice ``{"kind":
"pass_mode", "mode": "learn" | "greedy" | "explore"}``, taken up at the next episode boundary (or kick-off)
like the GetOpen advice. The learner reports to the coach on request, ``{"kind": "report", "what":
"transitions" | "snapshot"}``: its SMDP transitions since the last such report, or its non-zero weights
(:meth:`PlayerAgent.pending_reports`, sent by the socket loop as ``report`` messages, each below
:data:`REPORT_BYTES`; :func:`report_arrays` decodes one).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import replace
from typing import Any, Protocol

import numpy as np

from agents.belief import forget_episode, new_memory
from agents.keeper import NO_PASS_DECISION, PASS_DECISION_START, execute_pass_action, keeper_decide
from agents.policy_file import Policy, PolicyFileError, as_getopen_theta, getopen_theta_size
from agents.sarsa import MODE_GREEDY, MODE_NAMES, SarsaConfig, SarsaLearner
from agents.skills import (
    GETOPEN_POLICIES,
    PASS_POLICIES,
    AgentConfig,
)
from agents.state_vars import pass_state_size
from agents.taker import taker_decide
from agents.worldmodel import SIDE_CODES, WorldModel
from protocol import PROTOCOL_VERSION
from protocol import messages as m
from protocol.params import ServerParams
from server.world import CMD_DASH, CMD_KICK, CMD_TURN

log = logging.getLogger("keepaway.player")

TEAMS = ("keepers", "takers")
TIMING_MODES = ("sync", "realtime")
# Referee messages (spec `keepaway-agents.md` 1 step 1 and 6; docs/protocol.md 6 "hear").
EPISODE_MESSAGE = "training Keepaway 1"
KICK_OFF_MESSAGE = "play_on"
# The coach's policy advice: {"kind": "policy", "getopen_theta": [...] or float64 little-endian bytes}.
POLICY_ADVICE_KIND = "policy"
# The coach's Pass learning advice: {"kind": "pass_mode", "mode": one of PASS_MODES}.
PASS_MODE_ADVICE_KIND = "pass_mode"
PASS_MODES = MODE_NAMES
# The coach's report request: {"kind": "report", "what": REPORT_TRANSITIONS or REPORT_SNAPSHOT}.
REPORT_ADVICE_KIND = "report"
REPORT_TRANSITIONS = "transitions"
REPORT_SNAPSHOT = "snapshot"
# Payload bytes per report message: well below the server's 4 MiB message limit (protocol.endpoints
# DEFAULT_MAX_MESSAGE_BYTES) once msgpack framing and the server's player_report envelope are added;
# longer reports are sent in chunks.
REPORT_BYTES = 1 << 20
# Wire dtypes of the report arrays (little-endian; actions fit in int8, weight indices in uint32).
_REPORT_DTYPES = {"state": "<f8", "action": "<i1", "reward": "<f8", "next_action": "<i1", "terminal": "<u1",
                  "index": "<u4", "value": "<f8"}
# Arena size when init_ok's config does not give it (spec `keepaway-task.md` 1: 3 keepers vs 2 takers).
DEFAULT_KEEPERS = 3
DEFAULT_TAKERS = 2
# Atomic command name and number of arguments of each main command code (`server/world.py`).
_MAIN_COMMANDS = {CMD_DASH: ("dash", 1), CMD_TURN: ("turn", 1), CMD_KICK: ("kick", 2)}


class PassLearner(Protocol):
    """A keeper's Pass decision maker (spec `keepaway-agents.md` 5). ``state`` is the Pass state vector
    (4K + 2T - 3 floats); it is the agent's reused array, so copy it to keep it. Actions: 0 HoldBall,
    k >= 1 PassBall to the k-th nearest teammate. Rewards are in cycles."""

    def start(self, state: np.ndarray) -> int: ...

    def step(self, reward: float, state: np.ndarray) -> int: ...

    def end(self, reward: float) -> None: ...


PassLearnerFactory = Callable[[np.random.SeedSequence], PassLearner]
"""Builds a keeper's learner once its uniform number is known, from its own seed sequence."""


def sarsa_config(policy: Policy) -> SarsaConfig:
    """The tile-coding configuration a policy file's Pass weights were learned with (its header's
    ``config.sarsa``; the defaults of spec `keepaway-agents.md` 5 when absent)."""
    settings = policy.config.get("sarsa", {})
    try:
        return SarsaConfig(**settings)
    except (TypeError, ValueError) as exc:
        raise PolicyFileError(f"{policy.path}: bad config.sarsa: {exc}") from None


def sarsa_pass_factory(
    policy: Policy | None,
    mode: int = MODE_GREEDY,
    config: SarsaConfig | None = None,
    n_keepers: int = DEFAULT_KEEPERS,
    n_takers: int = DEFAULT_TAKERS,
) -> PassLearnerFactory:
    """The ``--pass learned`` learner of a player process: an SMDP Sarsa learner (spec
    `keepaway-agents.md` 5) in ``mode`` starting from the policy file's Pass weights (its sizes and
    ``config.sarsa``), or without a file from zero weights for ``n_keepers`` vs ``n_takers`` with
    ``config`` (default ``SarsaConfig()``). Its exploration stream is seeded by the first word of the
    keeper's seed sequence. Raises :class:`PolicyFileError` at once (before any game) when the file has
    no usable Pass weights."""
    if policy is None:
        config = config or SarsaConfig()
        return lambda seq: SarsaLearner(n_keepers, n_takers, config, int(seq.generate_state(1, np.uint64)[0]),
                                        mode)
    if policy.pass_weights is None:
        raise PolicyFileError(f"{policy.path}: this policy file has no Pass weights")
    config = sarsa_config(policy)
    arrays = policy.pass_arrays
    probe = SarsaLearner(policy.n_keepers, policy.n_takers, config, 0, mode)
    try:
        probe.load(arrays)
    except (KeyError, ValueError) as exc:
        raise PolicyFileError(f"{policy.path}: Pass weights do not fit the Sarsa learner: {exc}") from None

    def build(seq: np.random.SeedSequence) -> PassLearner:
        learner = SarsaLearner(policy.n_keepers, policy.n_takers, config,
                               int(seq.generate_state(1, np.uint64)[0]), mode)
        learner.load(arrays)
        return learner

    return build


def greedy_pass_factory(policy: Policy | None) -> PassLearnerFactory:
    """The policy file's SMDP Sarsa weights, frozen (greedy actions, no updates: spec
    `keepaway-agents.md` 5, evaluation mode); a file with Pass weights is required."""
    if policy is None:
        raise PolicyFileError("--pass learned needs a policy file with Pass weights (--policy FILE)")
    return sarsa_pass_factory(policy, MODE_GREEDY)


def _chunks(n: int, entry_bytes: int) -> list[slice]:
    """Slices of ``n`` entries of ``entry_bytes`` each, at most :data:`REPORT_BYTES` per slice (one
    empty slice when ``n`` is 0)."""
    per_chunk = max(1, REPORT_BYTES // max(1, entry_bytes))
    return [slice(i, min(i + per_chunk, n)) for i in range(0, n, per_chunk)] or [slice(0, 0)]


def _report_payloads(head: dict[str, Any], arrays: dict[str, np.ndarray], n: int,
                     first: int = 0) -> list[dict[str, Any]]:
    """``arrays`` (``n`` entries each along the first axis, numbered from ``first``) as report payloads
    of at most :data:`REPORT_BYTES` array bytes: ``head`` plus ``chunk``/``chunks``, ``first``/``count``
    (the chunk's entries) and each array as little-endian bytes (:data:`_REPORT_DTYPES`)."""
    wire = {name: np.ascontiguousarray(a, dtype=_REPORT_DTYPES[name]) for name, a in arrays.items()}
    entry_bytes = sum(a.nbytes // max(1, n) for a in wire.values())
    parts = _chunks(n, entry_bytes)
    return [{**head, "chunk": i, "chunks": len(parts), "first": first + part.start,
             "count": part.stop - part.start, **{name: a[part].tobytes() for name, a in wire.items()}}
            for i, part in enumerate(parts)]


def report_arrays(payload: dict[str, Any]) -> dict[str, Any]:
    """A report payload of :meth:`PlayerAgent.pending_reports` with its byte fields as numpy arrays
    (transition states reshaped to (count, n_vars)); the other fields unchanged."""
    out = dict(payload)
    for name, dtype in _REPORT_DTYPES.items():
        if name in out:
            out[name] = np.frombuffer(out[name], dtype=dtype)
    if "state" in out:
        out["state"] = out["state"].reshape(payload["count"], payload["n_vars"])
        out["terminal"] = out["terminal"].astype(bool)
    return out


class _Fields:
    """A message seen as the read-only mapping the world model's ``on_*`` methods take (no copy)."""

    __slots__ = ("msg",)

    def __init__(self) -> None:
        self.msg: Any = None

    def __getitem__(self, name: str) -> Any:
        return getattr(self.msg, name)


def agent_seed_sequence(seed: int, side_code: int, unum: int) -> np.random.SeedSequence:
    """A player's own randomness, derived from the run seed, its side and its uniform number, so which
    process connects first does not matter (architecture, Determinism); every mode derives it here."""
    return np.random.SeedSequence([int(seed), side_code, unum])


class PlayerAgent:
    """One keeper or taker, driven by decoded protocol messages (module docstring).

    ``pass_policy`` and ``getopen_policy`` name keys of :data:`PASS_POLICIES` and
    :data:`GETOPEN_POLICIES` (keepers only); ``policy`` is a loaded policy file (GO:L parameters, Pass
    weights); ``seed`` with the side and uniform number seeds the agent's own random stream
    (``SeedSequence([seed, side, unum])``, side 0 = keepers), so every player of a run is reproducible;
    ``fullstate`` uses the exact ``fullstate`` percepts (the player must ask for them in ``init``).
    ``pass_learner`` replaces the ``--pass learned`` learner (default: :func:`sarsa_pass_factory` on
    ``policy``, greedy until the coach's ``pass_mode`` advice).
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
    ) -> None:
        if team not in TEAMS:
            raise ValueError(f"team must be one of {TEAMS}, not {team!r}")
        if pass_policy not in PASS_POLICIES:
            raise ValueError(f"unknown Pass policy {pass_policy!r}; choose one of {list(PASS_POLICIES)}")
        if getopen_policy not in GETOPEN_POLICIES:
            raise ValueError(f"unknown GetOpen policy {getopen_policy!r}; choose one of {list(GETOPEN_POLICIES)}")
        if seed < 0:
            raise ValueError(f"seed must be >= 0, not {seed}")
        self.team = team
        self.is_keeper = team == "keepers"
        self.policy = policy
        self.seed = seed
        self.fullstate = fullstate
        self.config = replace(config or AgentConfig(), pass_policy=PASS_POLICIES[pass_policy],
                              getopen_policy=GETOPEN_POLICIES[getopen_policy])
        external = self.is_keeper and pass_policy == "learned"
        if pass_learner is not None and not external:
            raise ValueError("a Pass learner is only used by keepers with the 'learned' Pass policy")
        self._external = external
        self._learner_factory = pass_learner or (sarsa_pass_factory(policy) if external and policy else None)
        if self.is_keeper and getopen_policy == "learned" and policy is not None and policy.getopen_theta is None:
            raise PolicyFileError(f"{policy.path}: this policy file has no GetOpen weights (getopen_theta)")
        self.learner: PassLearner | None = None
        self.side: str | None = None
        self.unum: int | None = None
        self.mode: str | None = None
        self.episodes = 0  # episode boundaries heard
        self._pending_theta: np.ndarray | None = None
        self._pending_pass_mode: int | None = None
        self._reports: list[m.Report] = []
        self._reported = 0  # sequence number of the next transition to report
        self._started = False
        self._fields = _Fields()
        self._decide_on: type | None = None
        self._handlers: dict[type, Callable[[Any], m.Command | None]] = {
            m.InitOk: self._on_init_ok, m.SenseBody: self._on_sense_body, m.See: self._on_see,
            m.Fullstate: self._on_fullstate, m.Hear: self._on_hear, m.Think: self._on_think,
        }

    @property
    def ready(self) -> bool:
        """Whether ``init_ok`` has been received."""
        return self.side is not None

    def on_message(self, msg: m.Message) -> m.Command | None:
        """Take one decoded server message; return the command to send, if this message calls for one.
        ``error`` and ``shutdown`` are the transport's business and return None, as does anything
        before ``init_ok``."""
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
        policy = self.policy
        if self.is_keeper and policy is not None and (policy.n_keepers, policy.n_takers) != (n_keepers, n_takers):
            raise PolicyFileError(f"{policy.path}: the policy is for {policy.n_keepers} keepers and "
                                  f"{policy.n_takers} takers, the server plays {n_keepers} vs {n_takers}")
        params = ServerParams.from_dict(msg.params)
        self.wm = WorldModel(params, msg.side, msg.unum, n_keepers, n_takers, msg.landmarks["flags"])
        self.kp = self.wm.kp
        self.cfg = self.config.kernel()
        seq = agent_seed_sequence(self.seed, SIDE_CODES[msg.side], msg.unum)
        self.memory = new_memory(1, seq.generate_state(1, np.uint64))
        self.theta = np.zeros(getopen_theta_size(n_keepers, n_takers))
        if self.is_keeper and policy is not None and policy.getopen_theta is not None:
            self.theta[:] = policy.getopen_theta
        self.pass_state = np.zeros(pass_state_size(n_keepers, n_takers))
        self._out_main = np.zeros(1, dtype=np.int8)
        self._out_a1 = np.zeros(1)
        self._out_a2 = np.zeros(1)
        self._out_neck = np.zeros(1)
        factory = self._learner_factory
        if factory is None and self._external:
            factory = sarsa_pass_factory(None, n_keepers=n_keepers, n_takers=n_takers)
        if factory is not None:
            self.learner = factory(seq.spawn(1)[0])
        self.n_keepers, self.n_takers, self.mode = n_keepers, n_takers, mode
        self.side, self.unum = msg.side, msg.unum
        self._started = msg.play_mode == KICK_OFF_MESSAGE
        if mode == "sync":
            self._decide_on = m.Think
        else:
            self._decide_on = m.Fullstate if self.fullstate else m.SenseBody
        return None

    # -- percepts ----------------------------------------------------------------------------------
    def _view(self, msg: m.Message) -> _Fields:
        self._fields.msg = msg
        return self._fields

    def _on_sense_body(self, msg: m.SenseBody) -> m.Command | None:
        self.wm.on_sense_body(self._view(msg))
        return self._decide(msg.cycle) if self._decide_on is m.SenseBody else None

    def _on_see(self, msg: m.See) -> None:
        self.wm.on_see(self._view(msg))

    def _on_fullstate(self, msg: m.Fullstate) -> m.Command | None:
        if not self.fullstate:
            return None
        self.wm.on_fullstate(self._view(msg))
        return self._decide(msg.cycle) if self._decide_on is m.Fullstate else None

    def _on_think(self, msg: m.Think) -> m.Command | None:
        return self._decide(msg.cycle) if self._decide_on is m.Think else None

    def _on_hear(self, msg: m.Hear) -> None:
        if msg.sender == "referee":
            if msg.message == EPISODE_MESSAGE:
                self._episode_boundary(msg.cycle)
            elif msg.message == KICK_OFF_MESSAGE and not self._started:
                self._started = True
                self._apply_pending_policy()
        elif msg.sender == "coach":
            self._on_advice(msg.message, msg.cycle)

    # -- episodes and advice -----------------------------------------------------------------------
    def _episode_boundary(self, cycle: int) -> None:
        """Spec `keepaway-agents.md` 1 step 1: forget the objects, end the learner's episode with reward
        now - t_last (only if it decided in this episode), clear the decision memory, take up advice."""
        self.wm.forget()
        t_last = int(self.memory.t_last[0])
        if self.learner is not None and t_last >= 0:
            self.learner.end(float(cycle - t_last))
        forget_episode(self.memory, 0)
        self._apply_pending_policy()
        self.episodes += 1

    def _on_advice(self, payload: Any, cycle: int) -> None:
        """Keep the coach's GetOpen parameters or Pass learning mode for the next episode boundary (or
        kick-off), queue the reports it asks for; anything else the coach says is not for this agent. Bad
        advice is logged and ignored."""
        if not self.is_keeper or type(payload) is not dict:
            return
        kind = payload.get("kind")
        if kind == PASS_MODE_ADVICE_KIND:
            self._on_pass_mode_advice(payload.get("mode"))
        elif kind == REPORT_ADVICE_KIND:
            self._on_report_advice(payload.get("what"), cycle)
        elif kind == POLICY_ADVICE_KIND:
            self._on_policy_advice(payload)

    def _sarsa(self, what: str) -> bool:
        """Whether this keeper's Pass learner can serve ``what`` (a Sarsa learner's modes and reports);
        advice to a keeper without a learner is not for it, to one with another learner is logged."""
        if self.learner is None:
            return False
        if not isinstance(self.learner, SarsaLearner):
            log.warning("ignored the coach's %s advice: the Pass learner is not a Sarsa learner", what)
            return False
        return True

    def _on_pass_mode_advice(self, mode: Any) -> None:
        if mode not in PASS_MODES:
            log.warning("ignored the coach's pass_mode advice: mode %r is not one of %s", mode, list(PASS_MODES))
        elif self._sarsa("pass_mode"):
            self._pending_pass_mode = PASS_MODES[mode]

    def _on_report_advice(self, what: Any, cycle: int) -> None:
        """Queue the requested report at once (a report changes nothing in the game)."""
        if what not in (REPORT_TRANSITIONS, REPORT_SNAPSHOT):
            log.warning("ignored the coach's report request: %r is not %r or %r", what, REPORT_TRANSITIONS,
                        REPORT_SNAPSHOT)
        elif self._sarsa("report"):
            payloads = self._transition_payloads() if what == REPORT_TRANSITIONS else self._snapshot_payloads()
            self._reports += [m.Report(cycle=cycle, payload=p) for p in payloads]

    def _transition_payloads(self) -> list[dict[str, Any]]:
        """The learner's SMDP transitions since the last transitions report (``first`` = sequence number;
        ``dropped``: transitions lost from its ring buffer since then)."""
        logged = self.learner.transitions(self._reported)
        sequence = logged.pop("sequence")
        first = int(sequence[0]) if len(sequence) else int(self.learner.memory.log_count[0])
        head = {"kind": "pass_transitions", "episode": self.episodes, "dropped": first - self._reported,
                "n_vars": self.pass_state.size}
        self._reported = first + len(sequence)
        return _report_payloads(head, logged, len(sequence), first)

    def _snapshot_payloads(self) -> list[dict[str, Any]]:
        """The learner's non-zero weights, (index, value) pairs in index order."""
        index, value = self.learner.snapshot()
        head = {"kind": "pass_snapshot", "episode": self.episodes, "table_size": self.learner.config.table_size,
                "nonzero": len(index)}
        return _report_payloads(head, {"index": index, "value": value}, len(index))

    def pending_reports(self) -> list[m.Report]:
        """The ``report`` messages queued for the coach since the last call (the socket loop sends them)."""
        reports, self._reports = self._reports, []
        return reports

    def _on_policy_advice(self, payload: dict) -> None:
        values = payload.get("getopen_theta")
        if values is None:
            return
        try:
            if isinstance(values, bytes):
                values = np.frombuffer(values, dtype="<f8")
            self._pending_theta = as_getopen_theta(values, self.theta.size)
        except ValueError as exc:
            log.warning("ignored the coach's policy advice: %s", exc)

    def _apply_pending_policy(self) -> None:
        if self._pending_theta is not None:
            self.theta[:] = self._pending_theta
            self._pending_theta = None
        if self._pending_pass_mode is not None:
            self.learner.mode = self._pending_pass_mode
            self._pending_pass_mode = None

    # -- deciding ----------------------------------------------------------------------------------
    def _decide(self, cycle: int) -> m.Command:
        """Run the decision kernel for this cycle and turn its output into atomic commands."""
        bel = self.wm.belief()
        outs = (self._out_main, self._out_a1, self._out_a2, self._out_neck)
        if self.is_keeper:
            decision = keeper_decide(bel, 0, self.memory, self.theta, self.kp, self.cfg, *outs, self.pass_state)
            if decision != NO_PASS_DECISION and self.learner is not None:
                self._ask_learner(bel, decision, outs)
        else:
            taker_decide(bel, 0, self.memory, self.kp, self.cfg, *outs)
        main = int(self._out_main[0])
        a1, a2, neck = float(self._out_a1[0]), float(self._out_a2[0]), float(self._out_neck[0])
        self.wm.on_own_commands(main, a1, a2, neck)
        commands = [m.AtomicCommand("turn_neck", (neck,))]
        spec = _MAIN_COMMANDS.get(main)
        if spec is not None:
            name, n_args = spec
            commands.insert(0, m.AtomicCommand(name, (a1, a2)[:n_args]))
        return m.Command(cycle=cycle, commands=tuple(commands))

    def _ask_learner(self, bel: Any, decision: int, outs: tuple) -> None:
        """A Pass decision point with an external learner (agents/keeper.py docstring): start or step
        with reward = now - t_last, then execute its action."""
        if decision == PASS_DECISION_START:
            action = self.learner.start(self.pass_state)
        else:
            action = self.learner.step(float(bel.time[0] - self.memory.t_last[0]), self.pass_state)
        if not 0 <= action < self.n_keepers:
            raise ValueError(f"the Pass learner chose action {action}; actions are 0..{self.n_keepers - 1}")
        execute_pass_action(bel, 0, self.memory, int(action), self.kp, self.cfg, *outs)


def compile_kernels() -> None:
    """Run every kernel a player uses once, on a synthetic arena, so numba compiles them (or loads them
    from its cache) before a server waits for this player's answers."""
    from protocol.landmarks import to_wire
    from protocol.params import parameter_set

    params = parameter_set("classic")
    init = dict(version=PROTOCOL_VERSION, cycle=0, play_mode="play_on", params=params.to_dict(), landmarks=to_wire(),
                config={"mode": "sync", "keepers": DEFAULT_KEEPERS, "takers": DEFAULT_TAKERS})
    see = m.See(cycle=0, flags=((0, 10.0, 0, None, None), (1, 30.0, 40, 0.1, 0.2)), lines=(),
                ball=(2.0, 10, 0.1, 1.0),
                players=(("l", 2, 5.0, -20, 0.0, 0.0, 10, 10), (None, None, 30.0, 40, None, None, None, None)))
    body = m.SenseBody(cycle=0, view_mode=("high", "normal"), stamina=(4000.0, 1.0, -1.0), speed=(0.0, 0),
                       head_angle=0, counts={}, collision=())
    for team, side in (("keepers", "l"), ("takers", "r")):
        agent = PlayerAgent(team)
        agent.on_message(m.InitOk(side=side, unum=1, team=team, **init))
        for msg in (body, see, m.Think(cycle=0), m.Hear(cycle=0, sender="referee", message=EPISODE_MESSAGE)):
            agent.on_message(msg)
        if agent.is_keeper:
            execute_pass_action(agent.wm.belief(), 0, agent.memory, 0, agent.kp, agent.cfg, agent._out_main,
                                agent._out_a1, agent._out_a2, agent._out_neck)


__all__ = [
    "EPISODE_MESSAGE",
    "GETOPEN_POLICIES",
    "PASS_MODES",
    "PASS_POLICIES",
    "REPORT_BYTES",
    "PassLearner",
    "PassLearnerFactory",
    "PlayerAgent",
    "agent_seed_sequence",
    "compile_kernels",
    "greedy_pass_factory",
    "report_arrays",
    "sarsa_config",
    "sarsa_pass_factory",
]
