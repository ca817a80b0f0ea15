"""docs/rules.md against the code: its parameter table against ``protocol.params`` and its error-code
table against every code the server, the coach and the codec can send. Reads files only (no kernels)."""

from __future__ import annotations

import re
from dataclasses import fields
from pathlib import Path

from keepaway.protocol.errors import CODEC_ERROR_CODES, ERROR_CODES
from keepaway.protocol.params import CLASSIC, CURRENT, KEEPAWAY_LAUNCH, ServerParams

ROOT = Path(__file__).resolve().parent.parent
RULES = (ROOT / "docs" / "rules.md").read_text(encoding="utf-8")
# Where an error code can be given to a client: the codec, the server, the coach (and what they use).
SOURCE_DIRS = ("protocol", "server", "coach", "agents", "trainer")
CODE_PATTERNS = (
    r'code="([a-z_]+)"',  # Error(cycle=..., code="...")
    r'ArenaError\(\s*"([a-z_]+)"',
    r'ProtocolError\(\s*"([a-z_]+)"',
    r'Invalid\(\s*"([a-z_]+)"',
    r'_error_raw\([^()]*?,\s*"([a-z_]+)"',
)


def table_rows(marker: str) -> list[list[str]]:
    """The rows (cells stripped) of the markdown table right after the HTML comment ``marker``."""
    start = RULES.index(marker)
    rows = []
    for line in RULES[start:].splitlines()[1:]:
        if not line.startswith("|"):
            if rows:
                break
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if set("".join(cells)) <= set("-: "):
            continue
        rows.append(cells)
    return rows[1:]  # without the header


def shown(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return value
    return f"{value:g}"


def test_parameter_table_matches_the_parameter_sets():
    rows = table_rows("<!-- parameter table")
    names = [row[0].strip("`") for row in rows]
    assert names == [f.name for f in fields(ServerParams)], "one row per ServerParams field, in order"
    for name, classic, current, *_ in rows:
        name = name.strip("`")
        assert classic == shown(getattr(CLASSIC, name)), name
        assert current == shown(getattr(CURRENT, name)), name


def test_parameter_table_notes_the_launch_settings():
    rows = {row[0].strip("`"): row for row in table_rows("<!-- parameter table")}
    for name, value in KEEPAWAY_LAUNCH.items():
        assert f"launch: {shown(value)}" in rows[name][-1], name
    launched = [name for name, row in rows.items() if "launch:" in row[-1]]
    assert sorted(launched) == sorted(KEEPAWAY_LAUNCH)


def codes_in_source() -> set[str]:
    codes = set(CODEC_ERROR_CODES)
    for directory in SOURCE_DIRS:
        for path in (ROOT / directory).rglob("*.py"):
            text = path.read_text(encoding="utf-8")
            for pattern in CODE_PATTERNS:
                codes.update(re.findall(pattern, text))
    return codes


def test_error_table_lists_every_code_the_code_sends():
    documented = [row[0].strip("`") for row in table_rows("<!-- error table")]
    assert len(documented) == len(set(documented)), "each code once"
    source = codes_in_source()
    assert {"not_initialised", "bad_cycle", "dropped", "busy", "missed_cycles"} <= source  # the regexes work
    assert set(documented) == source
    assert source == set(ERROR_CODES) and len(ERROR_CODES) == len(set(ERROR_CODES))  # each declared once
