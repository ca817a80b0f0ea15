"""The one exception the protocol layer raises for bad input.

Every byte string that arrives on a socket is untrusted until decoded and validated (style guide,
"Sockets at the edge"); whatever is wrong with it, :func:`protocol.codec.decode` raises
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


class ProtocolError(Exception):
    """A message that cannot be accepted: ``code`` is short snake_case, ``message`` one line saying why."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(f"{code}: {message}")
        self.code = code
        self.message = message

    def __reduce__(self) -> tuple:
        return (type(self), (self.code, self.message))
