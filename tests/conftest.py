"""Shared fixtures: real ``keepaway`` processes on free loopback ports, always cleaned up."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
LISTEN_RE = re.compile(r"players=tcp://([\d.]+):(\d+) coach=tcp://[\d.]+:(\d+) monitor=tcp://[\d.]+:(\d+)")


@dataclass
class ServerProcess:
    proc: subprocess.Popen
    host: str
    players_port: int
    coach_port: int
    monitor_port: int
    log_dir: Path

    @property
    def players_endpoint(self) -> str:
        return f"tcp://{self.host}:{self.players_port}"

    @property
    def coach_endpoint(self) -> str:
        return f"tcp://{self.host}:{self.coach_port}"

    @property
    def monitor_endpoint(self) -> str:
        return f"tcp://{self.host}:{self.monitor_port}"

    def wait(self, timeout: float = 60.0) -> int:
        return self.proc.wait(timeout=timeout)

    def stderr_text(self) -> str:
        return self.proc.stderr.read().decode() if self.proc.stderr else ""


def keepaway_command(*args: str) -> list[str]:
    """The ``keepaway`` CLI run with this interpreter (works without the console script on PATH)."""
    return [sys.executable, "-m", "keepaway", *args]


class ProcessGroup:
    """Every process a test starts; all are killed at teardown, even when the test failed."""

    def __init__(self) -> None:
        self.procs: list[subprocess.Popen] = []

    def popen(self, args: list[str], **kwargs) -> subprocess.Popen:
        proc = subprocess.Popen(args, cwd=REPO, start_new_session=True, **kwargs)
        self.procs.append(proc)
        return proc

    def start_server(self, tmp_path: Path, *extra: str) -> ServerProcess:
        log_dir = tmp_path / "logs"
        proc = self.popen(
            keepaway_command("server", "--players-port", "0", "--coach-port", "0", "--monitor-port", "0",
                             "--log-dir", str(log_dir), "-v", *extra),
            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        deadline = time.monotonic() + 120
        line = b""
        while time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            match = LISTEN_RE.search(line.decode())
            if match:
                host, p, c, mon = match.groups()
                return ServerProcess(proc, host, int(p), int(c), int(mon), log_dir)
        proc.kill()
        raise RuntimeError(f"server did not start: {line!r} {proc.stderr.read().decode()[-2000:]}")

    def cleanup(self) -> None:
        for proc in self.procs:
            if proc.poll() is None:
                try:
                    os.killpg(proc.pid, signal.SIGTERM)
                except ProcessLookupError:
                    continue
        deadline = time.monotonic() + 5
        for proc in self.procs:
            try:
                proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                try:
                    os.killpg(proc.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                proc.wait()
        for proc in self.procs:
            for stream in (proc.stdout, proc.stderr):
                if stream is not None:
                    stream.close()


@pytest.fixture
def processes():
    group = ProcessGroup()
    try:
        yield group
    finally:
        group.cleanup()
