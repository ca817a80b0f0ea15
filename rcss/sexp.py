"""S-expressions as rcssserver writes and reads them: ``(see 12 ((f c) 3.1 -20) ((p "keepers" 2) 9 15))``.

A list is a Python list, an atom a ``str``; a quoted string keeps its quotes (``'"hello"'``) so a reader
can tell ``(say "x")`` from ``(say x)``, as rcssserver's grammar does. Untrusted text is bounded: nesting
at most ``MAX_DEPTH`` levels; anything that is not one balanced expression is ``SexpError``.

What a player sends rcssserver is not read as s-expressions but by rcssserver's own scanner, whose tokens
``command_tokens`` gives exactly (``(say hi)(done)`` is one token there, ``1.5.3`` two).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from types import MappingProxyType

MAX_DEPTH = 16  # a see nests three levels ((see ((f c) ...))); commands two
_TOKEN = re.compile(r'\s*(?:(\()|(\))|("(?:[^"\\]|\\.)*")|([^\s()"]+)|(\S))')

Sexp = list  # list[str | Sexp]


class SexpError(ValueError):
    """Text that is not one balanced s-expression (a one-line reason)."""


def parse_all(text: str, max_depth: int = MAX_DEPTH) -> list[Sexp]:
    """Every top-level expression of ``text`` in order: ``"(dash 100)(done)"`` -> ``[["dash", "100"],
    ["done"]]``. A top-level atom, an unbalanced or unterminated expression, a stray quote, or nesting
    deeper than ``max_depth`` is ``SexpError``; trailing whitespace and NUL bytes (C clients send the
    terminating NUL) are ignored."""
    text = text.rstrip("\x00 \t\r\n")
    stack: list[Sexp] = []
    done: list[Sexp] = []
    pos = 0
    while pos < len(text):
        match = _TOKEN.match(text, pos)
        if match is None:  # only trailing whitespace is left
            break
        pos = match.end()
        opening, closing, quoted, atom, other = match.groups()
        if opening:
            if len(stack) >= max_depth:
                raise SexpError(f"nested deeper than {max_depth} levels")
            stack.append([])
        elif closing:
            if not stack:
                raise SexpError(f"unbalanced ')' at character {match.start(2)}")
            finished = stack.pop()
            (stack[-1] if stack else done).append(finished)
        elif other is not None:
            raise SexpError(f"unterminated string at character {match.start(5)}")
        elif not stack:
            raise SexpError(f"text outside parentheses at character {match.start()}: {(quoted or atom)[:20]!r}")
        else:
            stack[-1].append(quoted if quoted is not None else atom)
    if stack:
        raise SexpError("unbalanced '(': the text ends inside an expression")
    return done


def parse_one(text: str, max_depth: int = MAX_DEPTH) -> Sexp:
    """The one expression ``text`` holds (``SexpError`` if it holds none or several)."""
    found = parse_all(text, max_depth)
    if len(found) != 1:
        raise SexpError(f"expected one expression, found {len(found)}")
    return found[0]


def unquote(atom: str) -> str:
    """``'"hello"'`` -> ``hello`` (rcssserver's strings have no escapes worth undoing); other atoms as
    they are."""
    return atom[1:-1] if len(atom) >= 2 and atom[0] == atom[-1] == '"' else atom


# ------------------------------------------------------------------------ rcssserver's command tokens

# rcssserver src/player_command_tok.lpp, a flex scanner: the longest match wins, a tie goes to the rule
# written first (the keywords, then the numbers, then the words). The keywords, by the token they make:
COMMAND_KEYWORDS = MappingProxyType({
    **{word: word for word in (
        "dash turn turn_neck change_focus kick long_kick catch say sense_body score move change_view "
        "compression bye done pointto attentionto tackle clang ear synch_see gaussian_see narrow normal wide "
        "low high on off our opp ver true false partial complete l r").split()},
    "left": "l", "right": "r", "p": "partial", "c": "complete",
})
STR_MAX = 8192  # a longer word or string is an error token (rcssserver src/player_command_tok.h)
SAY_CHARACTERS = re.compile(r"[0-9A-Za-z().+\-*/?<>_ ]*")  # those a say message may hold
_BLANKS = re.compile(r"[ \t\n]*")  # not "\r": a carriage return is an error token
_WORD = re.compile(r"[-_a-zA-Z0-9]*")
_INT = re.compile(r"[+-]?[0-9]+")
_REAL = re.compile(r"[+-]?[0-9]*\.[0-9]+")
_EXP = re.compile(r"[+-]?(?:[0-9]*\.[0-9]+|[0-9]+)[eE][+-]?[0-9]+")
_INT32, _INT64 = 2**31, 2**63


def atoi(digits: str) -> int:
    """C's ``atoi`` (``strtol`` cast to int) on ``[+-]?[0-9]+`` as glibc computes it: saturated to 64
    bits, then wrapped to 32: ``"4294967396"`` -> 100. rcssserver reads integers so (its scanner and
    ``%d``)."""
    magnitude = digits.lstrip("+-").lstrip("0")
    value = _INT64 if len(magnitude) > 19 else int(magnitude or "0")
    value = -value if digits.startswith("-") else value
    value = min(max(value, -_INT64), _INT64 - 1)
    return (value + _INT32) % (2 * _INT32) - _INT32


def _token_at(text: str, pos: int) -> tuple[str, str | int | float, int]:
    """The token starting at ``pos`` (no blank there): kind, value, end."""
    char = text[pos]

    def capped(kind: str, value: str, end: int, length: int) -> tuple[str, str, int]:
        return (kind, value, end) if length <= STR_MAX else ("error", char, end)

    if char == "(":
        if text.startswith("(say ", pos):  # "(say MESSAGE)" is one token, up to the last ')' of the run
            close = text.rfind(")", pos + 5, SAY_CHARACTERS.match(text, pos + 5).end())
            if close > pos + 5:
                return capped("unquoted_say", text[pos + 5:close], close + 1, close - pos - 4)
        return "(", char, pos + 1
    if char == ")":
        return ")", char, pos + 1
    if char == '"':
        end = SAY_CHARACTERS.match(text, pos + 1).end()
        if end > pos + 1 and text.startswith('"', end):
            return capped("str", text[pos:end + 1], end + 1, end + 1 - pos)
        return "error", char, pos + 1
    number_end, kind = pos, "int"
    for rule, name in ((_INT, "int"), (_REAL, "real"), (_EXP, "real")):
        match = rule.match(text, pos)
        if match and match.end() > number_end:  # a tie goes to the rule written first
            number_end, kind = match.end(), name
    word_end = _WORD.match(text, pos).end()
    if number_end > pos and number_end >= word_end:
        lexeme = text[pos:number_end]
        return kind, atoi(lexeme) if kind == "int" else float(lexeme), number_end
    if word_end > pos:
        word = text[pos:word_end]
        keyword = COMMAND_KEYWORDS.get(word)
        return (keyword, keyword, word_end) if keyword else capped("str", word, word_end, word_end - pos)
    return "error", char, pos + 1


def command_tokens(text: str) -> Iterator[tuple[str, str | int | float]]:
    """rcssserver's player command tokens of ``text``, lazily (the parser stops at its first error), as
    ``(kind, value)``: ``("(", "(")``, ``(")", ")")``, a keyword (``("dash", "dash")``; ``left`` gives
    ``"l"``, ``p`` gives ``"partial"``), ``("int", atoi)``, ``("real", atof)`` (``1e999`` is infinite),
    ``("str", text)`` (a word, or a quoted string with its quotes), ``("unquoted_say", message)`` for
    ``(say MESSAGE)`` whose message runs to the last ``)`` of the say characters that follow (so
    ``(say hi)(done)`` says ``hi)(done``), ``("error", char)`` for anything else (rcssserver
    src/player_command_tok.lpp). Any character beyond ASCII is an error token here; rcssserver's scanner,
    built 7-bit, reads such a byte with the wrong table rows (``"\\xe9"`` as a word; a datagram ending with
    byte 0x80 hangs it)."""
    pos = _BLANKS.match(text).end()
    while pos < len(text):
        kind, value, pos = _token_at(text, pos)
        yield kind, value
        pos = _BLANKS.match(text, pos).end()
