"""The repository speaks of the software, not of how it was made: no file it tracks (code, tests,
benchmarks, data, docs) names a work session, a task-tracker number, people who are not part of the
project, a path of one particular machine, or a document the repository does not contain. History goes
in CHANGELOG.md; citations go to the project's own docs or to public sources (tests/test_citations.py)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from repository_files import read_text, text_files

FORBIDDEN = {
    "a work session": r"\b[Ss]essions? \d",
    "a tracker issue": r"\b[Ii]ssues? #?\d",
    "an item of an issue": r"\b[Ii]tems? \d",
    "a machine path": r"(?<![\w.~-])/(?:work|root|home)/\w",
    "a folder beside the repository": r"\.\./shared\b",
    "a workplace folder": r"\bshared/(?:spec|rcss-traces|rcss-behaviour|reference-stack|tools)\b",
    "someone's jobs": r"\banother\s+engineer|\bsomeone\s+else",
    "a document the repository lacks": (r"\b[Ss]pec [`\d]|\bspec: \"|\bstyle guide\b|\bserver-physics\.md"
                                        r"|\bkeepaway-(?:agents|task)\.md|\barchitecture\.md"),
}
PATTERNS = {name: re.compile(pattern) for name, pattern in FORBIDDEN.items()}
# The CI script alone may name the CI machine's folder beside the checkout: it finds the reference stack's
# source archives there.
ALLOWED_IN = {".ci/run": {"a folder beside the repository", "a workplace folder"}}
FILES = text_files()  # this file too: its examples below are split so that none reads as what it shows


def findings(name: Path, text: str) -> list[str]:
    """``file:line: what`` for every forbidden phrase in ``text``."""
    found = []
    allowed = ALLOWED_IN.get(name.as_posix(), set())
    for number, line in enumerate(text.split("\n"), start=1):
        for what, pattern in PATTERNS.items():
            match = None if what in allowed else pattern.search(line)
            if match:
                found.append(f"{name}:{number}: {what}: {match.group(0)!r} in {line.strip()[:100]!r}")
    return found


def test_no_tracked_file_speaks_of_how_the_project_was_made():
    problems = [problem for name in FILES for problem in findings(name, read_text(name))]
    assert not problems, f"{len(problems)} lines:\n" + "\n".join(problems)


@pytest.mark.parametrize("line, what", [
    ("# measured in sess" "ion 33", "a work session"),
    ("(iss" "ue 12)", "a tracker issue"),
    ("see it" "em 2 of the list", "an item of an issue"),
    ("BUILD=/" "work/rcss-build/b", "a machine path"),
    ("../sh" "ared/build.sh", "a folder beside the repository"),
    ("`sh" "ared/rcss-traces`", "a workplace folder"),
    ("another engin" "eer's jobs", "someone's jobs"),
    ("(sp" "ec `keepaway-ag" "ents.md` 2.2)", "a document the repository lacks"),
    ("(style gu" "ide, \"Sockets at the edge\")", "a document the repository lacks"),
])
def test_each_pattern_catches_what_it_names(line, what):
    assert any(f": {what}: " in finding for finding in findings(Path("x.py"), line))


@pytest.mark.parametrize("line", [
    "start_new_session=True",
    "the coach lost its server session during the run",
    "tests/data/rcss-traces/README.md",
    "a Ray session, an HTTP session",
    "for name, table in rows.items():",
    "(docs/players.md §5.3)",
    "run(RunOptions(spec, episodes), progress=False)",
    "importlib.util.module_from_spec(spec)",
])
def test_the_patterns_leave_ordinary_words_alone(line):
    assert findings(Path("x.py"), line) == []
