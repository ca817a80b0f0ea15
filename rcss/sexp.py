"""S-expressions as rcssserver writes and reads them: ``(see 12 ((f c) 3.1 -20) ((p "keepers" 2) 9 15))``.

A list is a Python list, an atom a ``str``; a quoted string keeps its quotes (``'"hello"'``) so a reader
can tell ``(say "x")`` from ``(say x)``, as rcssserver's grammar does. Untrusted text is bounded: nesting
at most ``MAX_DEPTH`` levels; anything that is not one balanced expression is ``SexpError``.
"""

from __future__ import annotations

import re

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
