"""The README matches the repository: the paths it names exist, its command table lists every command,
every option of every command has a help text, and what a user creates in a checkout by following it
(the virtual environment, the commands' default output directories) is ignored by git."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import click
import pytest

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


def default_out_directories() -> list[str]:
    """The ``--out`` defaults of every command (``out``, ``train_out``, ...)."""
    return sorted({str(param.default) for _, command in all_commands(main) for param in command.params
                   if "--out" in getattr(param, "opts", ()) and isinstance(param.default, Path)})


def test_what_a_user_creates_in_a_checkout_is_ignored_by_git():
    if shutil.which("git") is None or not (REPO / ".git").exists():
        pytest.skip("not a git checkout")
    outs = default_out_directories()
    assert "out" in outs and "train_out" in outs
    created = [".venv/bin/python", "keepaway.egg-info/PKG-INFO", "agents/__pycache__/cli.cpython-311.pyc",
               ".pytest_cache/README.md", *(f"{out}/keepaway.kwy" for out in outs)]
    checked = subprocess.run(["git", "check-ignore", "--no-index", "--verbose", "--non-matching", *created],
                             cwd=REPO, capture_output=True, text=True)
    unignored = [line.split("\t")[-1] for line in checked.stdout.splitlines() if line.startswith("::")]
    assert not unignored, f"git would offer to commit {unignored}"
