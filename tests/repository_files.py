"""The repository's own text files, for the tests that read all of them (tests/test_citations.py,
tests/test_repository_text.py): the files git tracks, or, where git or its metadata is missing (an
unpacked source archive), every file under the repository but caches, virtual environments and builds."""

from __future__ import annotations

import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SKIPPED_DIRECTORIES = {".git", ".venv", "venv", "__pycache__", ".pytest_cache", ".ruff_cache", "build",
                       "dist", "node_modules"}
# A NUL byte among a file's first bytes marks it as binary (images, archives).
BINARY_PROBE_BYTES = 8192


def tracked_files() -> list[Path]:
    """The repository's files, relative to its root, sorted."""
    try:
        listing = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True, check=True)
        names = [name for name in listing.stdout.decode().split("\0") if name]
    except (OSError, subprocess.CalledProcessError):
        names = [str(path.relative_to(REPO)) for path in REPO.rglob("*")
                 if path.is_file() and not SKIPPED_DIRECTORIES.intersection(path.relative_to(REPO).parts)
                 and not path.name.endswith((".pyc", ".egg-info"))]
    return sorted(Path(name) for name in names if (REPO / name).is_file())


def text_files() -> list[Path]:
    """The tracked files that hold UTF-8 text (no NUL byte in their first bytes, decodable)."""
    texts = []
    for name in tracked_files():
        data = (REPO / name).read_bytes()
        if b"\0" in data[:BINARY_PROBE_BYTES]:
            continue
        try:
            data.decode("utf-8")
        except UnicodeDecodeError:
            continue
        texts.append(name)
    return texts


def read_text(name: Path) -> str:
    return (REPO / name).read_text(encoding="utf-8")
