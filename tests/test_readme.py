"""The README is a front door that matches the repository: short, the paths it names exist, its command
table lists every command; every option of every command has a help text and is described in docs/cli.md,
where the table's details live; what a user creates in a checkout by following it (the virtual
environment, the commands' default output directories) is ignored by git."""

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
CLI_DOC = (REPO / "docs" / "cli.md").read_text()
# `code` spans that name a path: letters, digits and ./_- with at least one slash (not options such as
# `--a/--b`, URLs, globs or placeholders).
PATH_RE = re.compile(r"`([A-Za-z0-9_.][A-Za-z0-9_.\-/]*/[A-Za-z0-9_.\-/]*)`")
# Paths that are not the repository's, named on purpose.
ELSEWHERE = ("~/", "/")


def named_paths(text: str) -> list[str]:
    return [token.rstrip("/") for token in PATH_RE.findall(text) if not token.startswith(ELSEWHERE)]


def test_the_readme_is_short():
    lines = README.splitlines()
    assert len(lines) <= 250
    assert len(README) <= 20_000
    long_lines = [n for n, line in enumerate(lines, 1) if len(line) > 200]
    assert not long_lines, f"README lines over 200 characters: {long_lines}"


def test_the_design_notes_stay_within_800_lines():
    assert len((REPO / "docs" / "design.md").read_text(encoding="utf-8").splitlines()) <= 800


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


def doc_sections(text: str) -> dict[str, str]:
    """The text under each heading of a Markdown page, up to the next heading, by the heading's words
    (code marks dropped)."""
    sections: dict[str, str] = {}
    heading = ""
    for line in text.splitlines():
        if line.startswith("#"):
            heading = line.lstrip("#").strip().replace("`", "")
            sections[heading] = ""
        else:
            sections[heading] = sections.get(heading, "") + line + "\n"
    return sections


def test_docs_cli_describes_every_option_of_every_command():
    sections = doc_sections(CLI_DOC)
    missing = [name for name, _ in all_commands(main) if name not in sections]
    assert not missing, f"docs/cli.md has no section for: {missing}"
    undescribed = [f"{name} {param.opts[0]}" for name, command in all_commands(main) for param in command.params
                   if isinstance(param, click.Option) and not any(opt in sections[name] for opt in param.opts)]
    assert not undescribed, f"options docs/cli.md does not describe under their command: {undescribed}"


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
