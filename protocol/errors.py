"""The one exception the protocol layer raises for bad input.

Every byte string that arrives on a socket is untrusted until decoded and validated
(docs/protocol.md §10); whatever is wrong with it, :func:`protocol.codec.decode` raises
:class:`ProtocolError` and nothing else, so the server's loop needs a single ``except`` to answer the
sender with an ``error`` message carrying the same ``code`` and ``message``.
"""

from __future__ import annotations

CODEC_ERROR_CODES: tuple[str, ...] = (
    "malformed",  # not one msgpack value, trailing bytes, nesting too deep, non-string map key, ext type
    "not_a_map",  # the value is valid msgpack but not a map
    "unknown_type",  # "type" names no message accepted on this port
    "unknown_field",  # a key the message type does not define
    "missing_field",  # a required key is absent
    "bad_type",  # a value of the wrong msgpack type (bool is not an int)
    "bad_value",  # right type, wrong value: out of range, not finite, not one of the allowed names
    "too_large",  # the frame, a string or a list is longer than its limit
    "bad_version",  # the client speaks another protocol version
    "unknown_command",  # an atomic command name that does not exist
)
"""The codes :func:`protocol.codec.decode` uses (docs/protocol.md, "Errors")."""

REQUEST_ERROR_CODES: tuple[str, ...] = (
    "not_initialised",  # a player or coach message before init / coach_init (or after bye)
    "already_initialised",  # init or reconnect on a connection that already is a player
    "no_more_player",  # init when the team (or the requested number) is full
    "no_such_player",  # reconnect to a number the team does not have
    "cannot_reconnect",  # reconnect to a number whose client still answers
    "illegal_teamname",  # the arena's own check of a team name (the decoder refuses it first)
    "bad_cycle",  # a command for a cycle the server has not reached
    "dropped",  # a warning: part of a command was not applied (a bad say, a low-quality view)
    "missed_cycles",  # a warning: the server stopped waiting for this player
    "over_budget",  # messages beyond the peer's budget of a cycle were dropped (counted)
    "busy",  # arena port: a run_episodes while another is served
    "reports_missing",  # arena port: the keepers' reports did not all arrive
    "arena_stopped",  # arena port: the coach stopped with a run pending
    "session_lost",  # arena port: the coach lost its server session during the run
)
"""The codes of messages that were decoded but refused, or of warnings (docs/rules.md §10)."""

ERROR_CODES: tuple[str, ...] = CODEC_ERROR_CODES + REQUEST_ERROR_CODES
"""Every code an ``error`` message may carry."""


class ProtocolError(Exception):
    """A message that cannot be accepted: ``code`` is short snake_case, ``message`` one line saying why."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(f"{code}: {message}")
        self.code = code
        self.message = message

    def __reduce__(self) -> tuple:
        return (type(self), (self.code, self.message))
