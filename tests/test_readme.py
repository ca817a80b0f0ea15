"""The README matches the repository: the paths it names exist, its command table lists every command,
and every option of every command has a help text."""

from __future__ import annotations

import re
from pathlib import Path

import click

from keepaway.cli import main

REPO = Path(__file__).resolve().parent.parent
README = (REPO / "README.md").read_text()
# `code` spans that name a path: letters, digits and ./_- with at least one slash (not options such as
# `--a/--b`, URLs, globs or placeholders).
PATH_RE = re.compile(r"`([A-Za-z0-9_.][A-Za-z0-9_.\-/]*/[A-Za-z0-9_.\-/]*)`")
# Paths that are not the repository's, named on purpose.
ELSEWHERE = ("~/", "/")


def named_paths(text: str) -> list[str]:
    return [token.rstrip("/") for token in PATH_RE.findall(text) if not token.startswith(ELSEWHERE)]


def test_every_repository_path_the_readme_names_exists():
    paths = named_paths(README) + re.findall(r"\]\(((?:docs|benchmarks|tests)/[^)#]+)", README)
    assert len(paths) > 10
    missing = [p for p in paths if not (REPO / p).exists()]
    assert not missing, f"README names paths that do not exist: {missing}"


def test_the_command_table_lists_every_command():
    listed = set(re.findall(r"^\| `keepaway ([a-z-]+)", README, flags=re.MULTILINE))
    assert listed == set(main.commands)


def all_commands(group: click.Group, prefix: str = "keepaway") -> list[tuple[str, click.Command]]:
    found = []
    for name, command in group.commands.items():
        found.append((f"{prefix} {name}", command))
        if isinstance(command, click.Group):
            found.extend(all_commands(command, f"{prefix} {name}"))
    return found


def test_every_option_of_every_command_has_a_help_text():
    missing = [f"{name} {param.opts[0]}" for name, command in all_commands(main) for param in command.params
               if isinstance(param, click.Option) and not param.help]
    assert not missing, f"options without help: {missing}"
