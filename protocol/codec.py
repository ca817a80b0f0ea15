"""msgpack encoding and validating decoding of protocol messages (docs/protocol.md).

A message is one msgpack map with string keys and a ``"type"`` string. Each message type is a frozen
dataclass whose fields are declared with :func:`wire`, naming the *loader* that validates the field's
wire value and converts it to its Python form (ints to floats where floats are expected, arrays to
tuples). Loaders are small hand-written closures, cheap enough to run on every command of every player
in every cycle; :func:`decode` raises :class:`~protocol.errors.ProtocolError` and nothing else, whatever
the bytes are (docs/protocol.md §10).
"""

from __future__ import annotations

import dataclasses
import math
import sys
import threading
from collections.abc import Callable, Mapping
from typing import Any, ClassVar, Self

import msgpack

from keepaway.protocol.endpoints import DEFAULT_MAX_MESSAGE_BYTES
from keepaway.protocol.errors import ProtocolError

PROTOCOL_VERSION = 1
"""Bumped on every incompatible change; ``init``/``reconnect``/``coach_init`` must carry exactly this."""

MAX_PAYLOAD_DEPTH = 32
"""Deepest nesting of arrays/maps inside a free payload (msgpack's own packer stops at 511)."""

MAX_EXACT_INT = 2**53
_MAX_FLOAT = sys.float_info.max
"""Largest integer magnitude accepted where a float is expected (every such int is an exact double)."""

Loader = Callable[[Any], Any]
"""Validates one wire value and returns its Python form; raises :class:`Invalid`."""

_KIND_NAMES = {
    type(None): "nil", bool: "bool", int: "int", float: "float", str: "str", bytes: "bin",
    list: "array", tuple: "array", dict: "map",
}
_SCALARS = (type(None), bool, float, str, bytes)
_SHOW_CHARS = 40


def kind(value: Any) -> str:
    """The msgpack name of a value's type, for error messages readable by non-Python clients."""
    return _KIND_NAMES.get(type(value), type(value).__name__)


def show(value: Any) -> str:
    """A short one-line rendering of a received scalar (it may be a 4 MB string); containers by kind."""
    if type(value) is str or type(value) is bytes:
        text = repr(value[:_SHOW_CHARS])
    elif type(value) is int and not -(10**20) < value < 10**20:
        return "a huge int"
    elif type(value) in _SCALARS or type(value) is int:
        text = repr(value)
    else:
        return kind(value)
    return text if len(text) <= _SHOW_CHARS else text[: _SHOW_CHARS - 3] + "..."


class Invalid(Exception):
    """A value rejected by a loader; containers add their position to ``path`` as the error rises."""

    def __init__(self, code: str, what: str) -> None:
        super().__init__(what)
        self.code = code
        self.what = what
        self.path: list[str] = []

    def at(self, segment: str) -> Invalid:
        self.path.append(segment)
        return self

    def error(self, message_type: str, field: str = "") -> ProtocolError:
        where = field + "".join(reversed(self.path))
        return ProtocolError(self.code, f"{message_type}{'.' if where else ''}{where}: {self.what}")


# ----------------------------------------------------------------------------------------------- loaders


def integer(lo: int, hi: int) -> Loader:
    """An int in [lo, hi]; bool is not an int."""

    def load(value: Any) -> int:
        if type(value) is not int:
            raise Invalid("bad_type", f"expected an int, got {kind(value)}")
        if not lo <= value <= hi:
            raise Invalid("bad_value", f"{show(value)} is outside {lo}..{hi}")
        return value

    return load


def number(value: Any) -> float:
    """A finite number as a float; ints are accepted (up to 2**53 in magnitude)."""
    if type(value) is float and -_MAX_FLOAT <= value <= _MAX_FLOAT:  # fast path; NaN fails both tests
        return value
    if type(value) is float:
        if math.isfinite(value):
            return value
        raise Invalid("bad_value", f"{value} is not a finite number")
    if type(value) is int:
        if -MAX_EXACT_INT <= value <= MAX_EXACT_INT:
            return float(value)
        raise Invalid("bad_value", f"{show(value)} is too large for a number")
    raise Invalid("bad_type", f"expected a number, got {kind(value)}")


def non_negative(value: Any) -> float:
    """A finite number >= 0 (distances, speeds, stamina)."""
    if type(value) is float and 0.0 <= value <= _MAX_FLOAT:  # fast path
        return value
    result = number(value)
    if result < 0.0:
        raise Invalid("bad_value", f"{result} is negative")
    return result


def boolean(value: Any) -> bool:
    if type(value) is not bool:
        raise Invalid("bad_type", f"expected a bool, got {kind(value)}")
    return value


def text(max_chars: int) -> Loader:
    """A string of at most ``max_chars`` characters (code points)."""

    def load(value: Any) -> str:
        if type(value) is not str:
            raise Invalid("bad_type", f"expected a str, got {kind(value)}")
        if len(value) > max_chars:
            raise Invalid("too_large", f"string of {len(value)} characters exceeds the limit of {max_chars}")
        return value

    return load


def choice(*names: str) -> Loader:
    """One of a fixed set of names."""
    allowed = frozenset(names)
    listing = " | ".join(names)

    def load(value: Any) -> str:
        if type(value) is not str:
            raise Invalid("bad_type", f"expected a str ({listing}), got {kind(value)}")
        if value not in allowed:
            raise Invalid("bad_value", f"{show(value)} is not one of {listing}")
        return value

    return load


def optional(load: Loader) -> Loader:
    """``nil`` or what ``load`` accepts."""

    def load_optional(value: Any) -> Any:
        return None if value is None else load(value)

    return load_optional


def _array(value: Any) -> list | tuple:
    if type(value) is not list and type(value) is not tuple:
        raise Invalid("bad_type", f"expected an array, got {kind(value)}")
    return value


def sequence(item: Loader, max_len: int) -> Loader:
    """An array of at most ``max_len`` elements, each checked by ``item``; returned as a tuple."""

    def load(value: Any) -> tuple:
        items = _array(value)
        if len(items) > max_len:
            raise Invalid("too_large", f"array of {len(items)} elements exceeds the limit of {max_len}")
        try:
            return tuple([item(element) for element in items])
        except Invalid as exc:
            raise exc.at(f"[{_first_failure(zip([item] * len(items), items))}]") from None

    return load


def fixed(*items: Loader) -> Loader:
    """An array of exactly ``len(items)`` elements, element i checked by ``items[i]``; a tuple."""
    size = len(items)

    def load(value: Any) -> tuple:
        elements = _array(value)
        if len(elements) != size:
            raise Invalid("bad_value", f"expected {size} elements, got {len(elements)}")
        try:
            return tuple([element_load(element) for element_load, element in zip(items, elements)])
        except Invalid as exc:
            raise exc.at(f"[{_first_failure(zip(items, elements))}]") from None

    return load


def row(accept: Callable[[Any], bool], load: Loader) -> Loader:
    """``load`` (a :func:`fixed` row, maybe :func:`optional`) with a fast path: a value ``accept`` passes as already
    valid is returned as a tuple without calling a loader per element. ``accept`` must only pass values ``load``
    returns unchanged (as a tuple); anything else goes through ``load``, so results and error messages
    are the same. Used for the percepts a client decodes every cycle."""

    def load_fast(value: Any) -> Any:
        return tuple(value) if accept(value) else load(value)

    load_fast.full = load  # type: ignore[attr-defined]  # what the fast path must agree with (tested)
    return load_fast


def rows(accept: Callable[[Any], bool], load_row: Loader, max_len: int) -> Loader:
    """:func:`sequence` of ``load_row`` with the fast path of :func:`row` for the whole array: one whose
    every element ``accept`` passes is returned as a tuple of tuples."""
    load = sequence(load_row, max_len)

    def load_fast(value: Any) -> Any:
        if type(value) is list and len(value) <= max_len and all(map(accept, value)):
            return tuple(map(tuple, value))
        return load(value)

    load_fast.full = load  # type: ignore[attr-defined]
    return load_fast


def is_finite_float(value: Any, lo: float = -_MAX_FLOAT) -> bool:
    """True for a float in [lo, max float] (so not NaN or infinite): the fast-path test of numbers."""
    return type(value) is float and lo <= value <= _MAX_FLOAT


def _first_failure(pairs: Any) -> int:
    """Index of the first (loader, value) pair that fails: the error path of :func:`sequence` and
    :func:`fixed`, whose fast path validates without tracking positions."""
    for index, (load, value) in enumerate(pairs):
        try:
            load(value)
        except Invalid:
            return index
    return -1


def _reject_keys(value: dict, known: Mapping[str, Any] | frozenset[str]) -> None:
    """Raise for the first key of ``value`` that is not a string or not in ``known``."""
    for key in value:
        if type(key) is not str:
            raise Invalid("malformed", f"map keys must be strings, got {kind(key)}")
    unknown = sorted(key for key in value if key not in known)
    if unknown:
        raise Invalid("unknown_field", f"unknown field {show(unknown[0])}")


def record(**entries: Loader) -> Loader:
    """A map with exactly these keys (all required), each value checked by its loader; a dict."""

    def load(value: Any) -> dict:
        if type(value) is not dict:
            raise Invalid("bad_type", f"expected a map, got {kind(value)}")
        out = {}
        for key, entry_load in entries.items():
            if key not in value:
                raise Invalid("missing_field", f"missing field {key!r}")
            try:
                out[key] = entry_load(value[key])
            except Invalid as exc:
                raise exc.at(f".{key}") from None
        if len(value) != len(entries):
            _reject_keys(value, entries)
        return out

    return load


def payload_value(value: Any) -> Any:
    """Any msgpack value without ext types: nil, bool, int, float (NaN allowed), str, bin, and arrays
    and string-keyed maps nested at most :data:`MAX_PAYLOAD_DEPTH` deep. Returned unchanged.

    The depth bound keeps every accepted payload re-encodable when the server relays it.
    """
    pending = [(value, 0)]
    while pending:
        item, depth = pending.pop()
        kind_of = type(item)
        if kind_of is list or kind_of is tuple or kind_of is dict:
            if depth >= MAX_PAYLOAD_DEPTH:
                raise Invalid("malformed", f"payload nested deeper than {MAX_PAYLOAD_DEPTH}")
            if kind_of is dict:
                for key in item:
                    if type(key) is not str:
                        raise Invalid("malformed", f"map keys must be strings, got {kind(key)}")
                children = item.values()
            else:
                children = item
            pending.extend((child, depth + 1) for child in children)
        elif kind_of is int:
            if not -(2**63) <= item < 2**64:
                raise Invalid("bad_value", f"{show(item)} does not fit in a msgpack int")
        elif kind_of not in _SCALARS:
            raise Invalid("bad_type", f"{kind(item)} is not allowed in a payload")
    return value


def protocol_version(value: Any) -> int:
    """The protocol version: an int equal to :data:`PROTOCOL_VERSION` (else ``bad_version``)."""
    if type(value) is not int:
        raise Invalid("bad_type", f"expected an int, got {kind(value)}")
    if value != PROTOCOL_VERSION:
        raise Invalid("bad_version", f"this side speaks protocol version {PROTOCOL_VERSION}, got {show(value)}")
    return value


# ---------------------------------------------------------------------------------------------- messages


def wire(
    load: Loader,
    *,
    default: Any = dataclasses.MISSING,
    required: bool | None = None,
    dump: Callable[[Any], Any] | None = None,
    key: str | None = None,
    omit_none: bool = False,
) -> Any:
    """Declare a message field: ``load`` validates its wire value, ``dump`` (if any) builds it.

    A field with a default may be omitted on the wire unless ``required`` says otherwise (the version
    field has a Python default for convenience but is always required on the wire). ``key`` is its wire
    name when that cannot be a Python name (``"pass"``); ``omit_none``: a None value is left out of the
    wire map instead of sent as nil (optional fields of the coach's advice, docs/advice.md).
    """
    metadata = {"load": load, "required": default is dataclasses.MISSING if required is None else required,
                "dump": dump, "key": key, "omit_none": omit_none}
    return dataclasses.field(default=default, metadata=metadata)


class Message:
    """Base of every message dataclass: the generic wire conversion driven by the :func:`wire` fields.

    ``TAG`` is the key naming the message's ``TYPE`` on the wire: ``"type"`` for the messages of the
    ports, ``"kind"`` for the coach's advice and the players' reports carried inside them
    (``protocol.advice``)."""

    __slots__ = ()
    TAG: ClassVar[str] = "type"
    TYPE: ClassVar[str]
    _WIRE: ClassVar[tuple[tuple[str, str, Loader, bool, Callable[[Any], Any] | None, bool], ...]]
    _NAMES: ClassVar[frozenset[str]]

    def to_wire(self) -> dict[str, Any]:
        """The msgpack-ready map: the tag then every field (defaults included unless ``omit_none``),
        string keys only."""
        out: dict[str, Any] = {self.TAG: self.TYPE}
        for name, key, _, _, dump, omit_none in self._WIRE:
            value = getattr(self, name)
            if value is None and omit_none:
                continue
            out[key] = value if dump is None else dump(value)
        return out

    @classmethod
    def from_wire(cls, data: Any) -> Self:
        """Validate a decoded map and build the message; raises only :class:`ProtocolError`."""
        if type(data) is not dict:
            raise ProtocolError("not_a_map", f"{cls.TYPE}: expected a map, got {kind(data)}")
        if data.get(cls.TAG) != cls.TYPE:
            raise ProtocolError("unknown_type", f"expected {cls.TAG} {cls.TYPE!r}, got {show(data.get(cls.TAG))}")
        values = {}
        for name, key, load, required, _, _ in cls._WIRE:
            if key in data:
                try:
                    values[name] = load(data[key])
                except Invalid as exc:
                    raise exc.error(cls.TYPE, key) from None
            elif required:
                raise ProtocolError("missing_field", f"{cls.TYPE}: missing field {key!r}")
        if len(data) != len(values) + 1:
            try:
                _reject_keys(data, cls._NAMES)
            except Invalid as exc:
                raise exc.error(cls.TYPE) from None
        result = cls(**values)
        try:
            result._check()
        except Invalid as exc:
            raise exc.error(cls.TYPE) from None
        return result

    def _check(self) -> None:
        """Rules that relate several fields; raises :class:`Invalid`. None by default."""


def message(cls: type | None = None, *, eq: bool = True) -> Any:
    """Class decorator: make ``cls`` a frozen keyword-only dataclass and record its wire fields.
    ``eq=False`` keeps the equality the class inherits (messages holding numpy arrays compare by their
    wire form, ``protocol.advice``)."""

    def make(cls: type) -> type:
        cls = dataclasses.dataclass(frozen=True, kw_only=True, slots=True, eq=eq)(cls)
        cls._WIRE = tuple(
            (f.name, f.metadata["key"] or f.name, f.metadata["load"], f.metadata["required"], f.metadata["dump"],
             f.metadata["omit_none"])
            for f in dataclasses.fields(cls)
        )
        cls._NAMES = frozenset(entry[1] for entry in cls._WIRE) | {cls.TAG}
        return cls

    return make if cls is None else make(cls)


# ----------------------------------------------------------------------------------------------- codec


_packers = threading.local()  # a Packer per thread: one is not to be shared while it packs


def encode(msg: Message) -> bytes:
    """One msgpack map (``use_bin_type``: bytes stay bin, str stays str). The bytes of ``msgpack.packb``,
    by a Packer kept for the thread rather than one made per call (1.5 us instead of 2.6 for a player's
    command; a game encodes a few of these a cycle per player)."""
    packer = getattr(_packers, "packer", None)
    if packer is None:
        packer = _packers.packer = msgpack.Packer(use_bin_type=True)
    return packer.pack(msg.to_wire())


def decode(
    data: bytes | bytearray | memoryview,
    allowed: Mapping[str, type[Message]],
    max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES,
) -> Message:
    """Decode one frame as one of the ``allowed`` message types (keyed by ``TYPE``).

    Raises :class:`ProtocolError` for any input that is not exactly one valid message (docs/protocol.md,
    "Errors"); never anything else.
    """
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise ProtocolError("malformed", f"expected bytes, got {type(data).__name__}")
    size = data.nbytes if isinstance(data, memoryview) else len(data)
    if size > max_bytes:
        raise ProtocolError("too_large", f"frame of {size} bytes exceeds the limit of {max_bytes}")
    try:
        value = msgpack.unpackb(data, raw=False, strict_map_key=True)
    except msgpack.ExtraData:
        raise ProtocolError("malformed", "trailing bytes after the msgpack value") from None
    except msgpack.StackError:
        raise ProtocolError("malformed", "msgpack value nested too deep") from None
    except Exception as exc:  # noqa: BLE001 - msgpack reports bad input with several exception types
        reason = " ".join(str(exc).split())[:120] or type(exc).__name__
        raise ProtocolError("malformed", f"not a msgpack value: {reason}") from None
    return load_tagged(value, allowed)


def tagged_type(value: Any, allowed: Mapping[str, type[Message]], tag: str = "type",
                what: str = "a message") -> type[Message]:
    """The class of ``allowed`` a decoded value names by its ``tag``; :class:`ProtocolError` if it is not
    a map, has no such tag, or names no allowed type."""
    if type(value) is not dict:
        raise ProtocolError("not_a_map", f"{what} is a msgpack map, got {kind(value)}")
    if tag not in value:
        raise ProtocolError("missing_field", f"{what} has no {tag!r}")
    name = value[tag]
    if type(name) is not str:
        raise ProtocolError("bad_type", f"{tag!r} must be a str, got {kind(name)}")
    cls = allowed.get(name)
    if cls is None:
        raise ProtocolError("unknown_type", f"{show(name)} is not accepted here; expected one of {', '.join(allowed)}")
    return cls


def load_tagged(value: Any, allowed: Mapping[str, type[Message]], tag: str = "type",
                what: str = "a message") -> Message:
    """An already unpacked value as one of the ``allowed`` types (:func:`tagged_type`), validated;
    raises :class:`ProtocolError` and nothing else."""
    return tagged_type(value, allowed, tag, what).from_wire(value)
