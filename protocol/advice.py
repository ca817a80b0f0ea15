"""The coach's advice to the players and the keepers' reports to the coach (docs/advice.md).

Advice travels as the free ``payload`` of an ``advice`` (delivered as a ``hear`` from ``"coach"``), a
report as the ``payload`` of a ``report`` (relayed as ``player_report``); a trainer's ``run_episodes``
carries advice and its answer ``episodes_done`` the reports (``protocol.arena``). Inside those payloads
each kind is a message of its own, declared once here as a frozen dataclass with the codec of
``protocol.codec``: a msgpack map whose ``"kind"`` names the dataclass, every field validated on the way
in (types, ranges, the sizes of its arrays), :class:`~protocol.errors.ProtocolError` and nothing else for
bad input. They are part of the protocol of :data:`~protocol.codec.PROTOCOL_VERSION`: the server admits a
coach and players only if they speak that version, so they agree on these forms too.

Arrays travel as little-endian ``bin`` (:data:`ARRAY_DTYPES`) and are read-only numpy arrays once
decoded; such messages compare equal when their wire forms are equal. Cutting the learner's arrays into
chunks and putting them together again is the keepers' business (``agents.pass_wire``): here each chunk
is checked on its own.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from keepaway.protocol.codec import (
    Invalid,
    Loader,
    Message,
    boolean,
    choice,
    integer,
    kind,
    load_tagged,
    message,
    number,
    optional,
    sequence,
    show,
    tagged_type,
    wire,
)
from keepaway.protocol.errors import ProtocolError
from keepaway.protocol.messages import COUNT, _by_type

ADVICE_TAG = "kind"  # the key naming an advice's or a report's kind
# The names a policy advice may switch to (``keepaway player --pass/--getopen``; agents.config maps
# them to the kernels' codes).
PASS_POLICY_NAMES = ("random", "handcoded", "learned", "hold")
GETOPEN_POLICY_NAMES = ("random", "handcoded", "handcoded-cone", "learned")
# The Sarsa learner's modes (agents.sarsa.MODE_NAMES maps them to the kernels' codes).
PASS_MODES = ("learn", "greedy", "explore")
# What a report advice may ask for; each is answered by the report kind of REPORTED.
REPORT_TRANSITIONS = "transitions"
REPORT_SNAPSHOT = "snapshot"
REPORTS = (REPORT_TRANSITIONS, REPORT_SNAPSHOT)
# The byte order and width of every array field.
ARRAY_DTYPES: Mapping[str, str] = {
    "getopen_theta": "<f8", "state": "<f8", "action": "<i1", "reward": "<f8", "next_action": "<i1",
    "terminal": "<u1", "index": "<u4", "check": "<i4", "value": "<f8", "hash_counts": "<i8",
}
HASH_COUNTS = 3  # the collision table's counters: calls, clear hits, collisions
MAX_TABLE_SIZE = 1 << 32  # slot indices are uint32
MAX_CHUNKS = 1 << 32
MAX_ENTRIES = 1 << 32
MAX_THETA = 1 << 16  # GO:L parameters as a msgpack array (bin is bounded by the frame)
MAX_CONFIG_FIELDS = 64
MAX_STATE_VARS = 1024
MAX_SEED_VALUE = 2**64 - 1  # any non-negative msgpack int
_SPARSE_FIELDS = ("config", "table_size", "hash_counts", "index", "check", "value")
_TRANSITION_FIELDS = ("dropped", "n_vars", "state", "action", "reward", "next_action", "terminal")


# ----------------------------------------------------------------------------------------------- loaders


def bin_array(dtype: str, finite: bool = False) -> Loader:
    """``bin`` holding whole values of ``dtype``, as a read-only numpy array; ``finite``: no NaN or
    infinity."""
    dt = np.dtype(dtype)

    def load(value: Any) -> np.ndarray:
        if type(value) is not bytes:
            raise Invalid("bad_type", f"expected bin of {dtype} values, got {kind(value)}")
        if len(value) % dt.itemsize:
            raise Invalid("bad_value", f"{len(value)} bytes are not a whole number of {dtype} values")
        array = np.frombuffer(value, dtype=dt)
        if finite and not np.isfinite(array).all():
            raise Invalid("bad_value", f"{int((~np.isfinite(array)).sum())} non-finite values")
        return array

    return load


def _dump_array(dtype: str) -> Any:
    return lambda array: np.ascontiguousarray(array, dtype=dtype).tobytes()


def _array_field(name: str, finite: bool = False, required: bool = False) -> Any:
    """An array field of dtype ``ARRAY_DTYPES[name]``; optional ones are left out of the wire when None."""
    dtype = ARRAY_DTYPES[name]
    if required:
        return wire(bin_array(dtype, finite), dump=_dump_array(dtype))
    return wire(optional(bin_array(dtype, finite)), default=None, dump=_dump_array(dtype), omit_none=True)


_theta_list = sequence(number, MAX_THETA)
_theta_bin = bin_array(ARRAY_DTYPES["getopen_theta"], finite=True)


def _getopen_theta(value: Any) -> np.ndarray:
    """The GO:L parameters: an array of finite numbers or bin of float64."""
    if type(value) is bytes:
        return _theta_bin(value)
    array = np.array(_theta_list(value), dtype=ARRAY_DTYPES["getopen_theta"])
    array.flags.writeable = False
    return array


def _sarsa_config(value: Any) -> dict:
    """The learner's ``SarsaConfig`` as a map of names to bools, ints and finite floats (the learner
    checks the names and values it knows)."""
    if type(value) is not dict:
        raise Invalid("bad_type", f"expected a map, got {kind(value)}")
    if len(value) > MAX_CONFIG_FIELDS:
        raise Invalid("too_large", f"map of {len(value)} entries exceeds the limit of {MAX_CONFIG_FIELDS}")
    for key, entry in value.items():
        if type(key) is not str:
            raise Invalid("malformed", f"map keys must be strings, got {kind(key)}")
        if type(entry) not in (bool, int, float):
            raise Invalid("bad_type", f"{show(key)} is a {kind(entry)}, expected a bool or a number")
        if type(entry) is float and not math.isfinite(entry):
            raise Invalid("bad_value", f"{show(key)} is {entry}, not a finite number")
    return value


def _table_size(value: Any) -> int:
    """A power of 2 the slot indices can address (collision_table, docs/players.md §6.3)."""
    size = integer(2, MAX_TABLE_SIZE)(value)
    if size & (size - 1):
        raise Invalid("bad_value", f"{size} is not a power of 2")
    return size


def _sizes(message_: Message, names: tuple[str, ...], count: int) -> None:
    """Each array field of ``names`` holds ``count`` values."""
    for name in names:
        size = len(getattr(message_, name))
        if size != count:
            raise Invalid("bad_value", f"{name} holds {size} values, expected {count}")


def _present(message_: Message, names: tuple[str, ...], present: bool, why: str) -> None:
    """Every field of ``names`` is given (``present``) or none is."""
    for name in names:
        if (getattr(message_, name) is not None) != present:
            code = "missing_field" if present else "bad_value"
            raise Invalid(code, f"{'missing' if present else 'unexpected'} field {name!r} {why}")


# ---------------------------------------------------------------------------------------------- messages


class Payload(Message):
    """An advice or a report: a message inside a payload, named by ``"kind"``; equal when the wire forms
    are (its arrays compare by value)."""

    __slots__ = ()
    TAG: ClassVar[str] = ADVICE_TAG

    def __eq__(self, other: object) -> bool:
        return type(other) is type(self) and self.to_wire() == other.to_wire()

    __hash__ = None  # type: ignore[assignment]


@message(eq=False)
class PolicyAdvice(Payload):
    """New GO:L parameters (on the raw state variables) and a switch of the Pass and GetOpen policies,
    each optional (docs/advice.md §2, "policy")."""

    TYPE: ClassVar[str] = "policy"
    getopen_theta: np.ndarray | None = wire(optional(_getopen_theta), default=None, omit_none=True,
                                            dump=_dump_array(ARRAY_DTYPES["getopen_theta"]))
    pass_policy: str | None = wire(optional(choice(*PASS_POLICY_NAMES)), default=None, key="pass", omit_none=True)
    getopen_policy: str | None = wire(optional(choice(*GETOPEN_POLICY_NAMES)), default=None, key="getopen",
                                      omit_none=True)


@message(eq=False)
class PassModeAdvice(Payload):
    """The Sarsa learner's mode (docs/advice.md §2, "pass_mode")."""

    TYPE: ClassVar[str] = "pass_mode"
    mode: str = wire(choice(*PASS_MODES))


@message(eq=False)
class SeedAdvice(Payload):
    """Restart every random stream of the player as if started with ``seed`` (docs/advice.md §2, "seed")."""

    TYPE: ClassVar[str] = "seed"
    seed: int = wire(integer(0, MAX_SEED_VALUE))


@message(eq=False)
class ReportRequest(Payload):
    """Ask every keeper for a report at once: its SMDP ``transitions`` or its Pass ``snapshot``."""

    TYPE: ClassVar[str] = "report"
    what: str = wire(choice(*REPORTS))


@message(eq=False)
class Chunk(Payload):
    """The position of one chunk of data cut into ``chunks`` messages: entries ``first`` ..
    ``first + count - 1`` (docs/advice.md §1, "Chunks")."""

    chunk: int = wire(integer(0, MAX_CHUNKS - 1))
    chunks: int = wire(integer(1, MAX_CHUNKS))
    first: int = wire(integer(0, MAX_ENTRIES))
    count: int = wire(integer(0, MAX_ENTRIES))

    def _check(self) -> None:
        if self.chunk >= self.chunks:
            raise Invalid("bad_value", f"chunk {self.chunk} of {self.chunks}: chunks are numbered 0 .. chunks - 1")


@message(eq=False)
class SparsePassChunk(Chunk):
    """One chunk of a keeper's Pass policy in the sparse form (docs/advice.md §4): the learner's
    ``config``, ``table_size`` and ``hash_counts`` (the same in every chunk), and ``count`` occupied slots
    (``index``, collision ``check`` value, weight ``value``)."""

    config: dict | None = wire(optional(_sarsa_config), default=None, omit_none=True)
    table_size: int | None = wire(optional(_table_size), default=None, omit_none=True)
    hash_counts: np.ndarray | None = _array_field("hash_counts")
    index: np.ndarray | None = _array_field("index")
    check: np.ndarray | None = _array_field("check")
    value: np.ndarray | None = _array_field("value", finite=True)

    def _check_policy(self, present: bool, why: str) -> None:
        """The sparse fields are all there and agree (``present``), or none is there."""
        Chunk._check(self)
        _present(self, _SPARSE_FIELDS, present, why)
        if not present:
            return
        if self.config.get("table_size") != self.table_size:
            raise Invalid("bad_value", f"table_size {self.table_size} is not the config's "
                                       f"{show(self.config.get('table_size'))}")
        _sizes(self, ("hash_counts",), HASH_COUNTS)
        _sizes(self, ("index", "check", "value"), self.count)
        if self.count and int(self.index.max()) >= self.table_size:
            raise Invalid("bad_value", f"slot index {int(self.index.max())} is outside the table of {self.table_size}")


@message(eq=False)
class PassLoadAdvice(SparsePassChunk):
    """One chunk of a keeper's whole Pass policy to play from the next boundary (docs/advice.md §2,
    "pass_load")."""

    TYPE: ClassVar[str] = "pass_load"

    def _check(self) -> None:
        self._check_policy(True, "in a pass_load")


@message(eq=False)
class PassSnapshotReport(SparsePassChunk):
    """A keeper's answer to a ``snapshot`` request: one chunk of its Pass policy, or with ``learner``
    false (no Sarsa learner) one empty chunk (docs/advice.md §3)."""

    TYPE: ClassVar[str] = "pass_snapshot"
    learner: bool = wire(boolean)
    episode: int = wire(COUNT)  # the episode boundaries the keeper has heard

    def _check(self) -> None:
        self._check_policy(self.learner, f"with learner {str(self.learner).lower()}")
        if not self.learner and (self.chunks, self.count) != (1, 0):
            raise Invalid("bad_value", "a report without a learner is one chunk of no entries")


@message(eq=False)
class PassTransitionsReport(Chunk):
    """A keeper's answer to a ``transitions`` request: the SMDP transitions ``first`` .. ``first + count
    - 1`` it logged since its previous such report (``dropped``: lost from its ring buffer meanwhile);
    with ``learner`` false one empty chunk (docs/advice.md §3)."""

    TYPE: ClassVar[str] = "pass_transitions"
    learner: bool = wire(boolean)
    episode: int = wire(COUNT)
    dropped: int | None = wire(optional(integer(0, MAX_ENTRIES)), default=None, omit_none=True)
    n_vars: int | None = wire(optional(integer(1, MAX_STATE_VARS)), default=None, omit_none=True)
    state: np.ndarray | None = _array_field("state")  # count x n_vars, row by row
    action: np.ndarray | None = _array_field("action")
    reward: np.ndarray | None = _array_field("reward")
    next_action: np.ndarray | None = _array_field("next_action")
    terminal: np.ndarray | None = _array_field("terminal")

    def _check(self) -> None:
        Chunk._check(self)
        _present(self, _TRANSITION_FIELDS, self.learner, f"with learner {str(self.learner).lower()}")
        if not self.learner:
            if (self.chunks, self.count) != (1, 0):
                raise Invalid("bad_value", "a report without a learner is one chunk of no entries")
            return
        _sizes(self, ("action", "reward", "next_action", "terminal"), self.count)
        _sizes(self, ("state",), self.count * self.n_vars)
        if self.count and (self.action.min() < 0 or self.next_action.min() < -1 or self.terminal.max() > 1):
            raise Invalid("bad_value", "actions must be >= 0, next actions >= -1 (terminal) and terminal 0 or 1")

    def arrays(self) -> dict[str, np.ndarray]:
        """The transitions as arrays: ``state`` (count, n_vars), ``action``, ``reward``, ``next_action``,
        ``terminal`` (bool). Only for a report with a learner."""
        return {"state": np.asarray(self.state).reshape(self.count, self.n_vars), "action": self.action,
                "reward": self.reward, "next_action": self.next_action,
                "terminal": np.asarray(self.terminal).astype(bool)}


CoachAdvice = PolicyAdvice | PassModeAdvice | PassLoadAdvice | SeedAdvice | ReportRequest
KeeperReport = PassTransitionsReport | PassSnapshotReport

ADVICE_KINDS: Mapping[str, type[Message]] = _by_type(PolicyAdvice, PassModeAdvice, PassLoadAdvice, SeedAdvice,
                                                     ReportRequest)
REPORT_KINDS: Mapping[str, type[Message]] = _by_type(PassTransitionsReport, PassSnapshotReport)
# The report kind that answers each request of REPORTS.
REPORTED: Mapping[str, type[Message]] = {REPORT_TRANSITIONS: PassTransitionsReport, REPORT_SNAPSHOT: PassSnapshotReport}


def advice_kind(payload: Any) -> type[Message] | None:
    """The advice class a payload names, or None when it names none (a player ignores it silently: not a
    map, no ``kind``, a kind it does not know)."""
    try:
        return tagged_type(payload, ADVICE_KINDS, ADVICE_TAG, "advice")
    except ProtocolError:
        return None


def decode_advice(payload: Any) -> CoachAdvice:
    """A coach's advice payload as its message; raises :class:`ProtocolError` (one line) for anything
    else."""
    return load_tagged(payload, ADVICE_KINDS, ADVICE_TAG, "advice")  # type: ignore[return-value]


def decode_report(payload: Any) -> KeeperReport:
    """A keeper's report payload as its message; raises :class:`ProtocolError` (one line) for anything
    else."""
    return load_tagged(payload, REPORT_KINDS, ADVICE_TAG, "a report")  # type: ignore[return-value]


def _nested(decoder: Any) -> Loader:
    """``decoder`` as a loader of a field of another message (its error becomes that field's)."""

    def load(value: Any) -> Any:
        try:
            return decoder(value)
        except ProtocolError as exc:
            raise Invalid(exc.code, exc.message) from None

    return load


advice_value = _nested(decode_advice)
report_value = _nested(decode_report)


__all__ = [
    "ADVICE_KINDS", "ARRAY_DTYPES", "CoachAdvice", "GETOPEN_POLICY_NAMES", "HASH_COUNTS", "KeeperReport",
    "PASS_MODES", "PASS_POLICY_NAMES", "PassLoadAdvice", "PassModeAdvice", "PassSnapshotReport",
    "PassTransitionsReport", "PolicyAdvice", "REPORTED", "REPORTS", "REPORT_KINDS", "REPORT_SNAPSHOT",
    "REPORT_TRANSITIONS", "ReportRequest",
    "SeedAdvice", "SparsePassChunk", "advice_kind", "advice_value", "decode_advice", "decode_report",
    "report_value",
]
