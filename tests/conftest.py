"""Shared fixtures: real ``keepaway`` processes on free loopback ports, always cleaned up.

No test can hang on a child's output: every process writes its stderr to a file (a server logging
fifty lines a second would otherwise fill an unread 64 KiB pipe and block in write()), and the line a
server announces its ports with is read with a deadline, never with a blocking readline.
"""

from __future__ import annotations

import os
import re
import selectors
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
LISTEN_RE = re.compile(r"players=tcp://([\d.]+):(\d+) coach=tcp://[\d.]+:(\d+) monitor=tcp://[\d.]+:(\d+)"
                       r"(?: rcss=udp://[\d.]+:(\d+))?\n")
START_TIMEOUT_S = 120.0  # a server compiles (or loads) its numba kernels before it announces its ports
FOLLOW_INTERVAL_S = 0.02  # how often a stderr file is looked at for new output (stderr=PIPE callers)
TAIL_CHARS = 3000  # how much of a process's stderr a failure message shows


@dataclass
class ServerProcess:
    proc: subprocess.Popen
    host: str
    players_port: int
    coach_port: int
    monitor_port: int
    log_dir: Path
    stderr_path: Path
    rcss_port: int | None = None  # the rcssserver-protocol front's UDP port (``--rcss-port``)

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
        """What the server has logged so far (all of it once it has exited)."""
        return self.stderr_path.read_text(errors="replace")


def keepaway_command(*args: str) -> list[str]:
    """The ``keepaway`` CLI run with this interpreter (works without the console script on PATH)."""
    return [sys.executable, "-m", "keepaway", *args]


# multiprocessing's helpers beside a distributed arena's members: the players' fork server
# (runner.launch) and its resource tracker
MULTIPROCESSING_HELPERS = ("multiprocessing.forkserver", "multiprocessing.resource_tracker")


def process_tree(pid: int) -> dict[int, str]:
    """pid -> name of every live (not zombie) descendant of ``pid``, from /proc: a forked player
    (runner.launch) by the member name it takes ("keeper 1", "taker 2"), any other process by its
    command line."""
    parent, name = {}, {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            state, ppid = (entry / "stat").read_text().rsplit(") ", 1)[1].split()[:2]
            comm = (entry / "comm").read_text().strip()
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except (OSError, ValueError, IndexError):
            continue
        if state != "Z":
            parent[int(entry.name)] = int(ppid)
            name[int(entry.name)] = comm if re.fullmatch(r"(keeper|taker) \d+", comm) else cmdline
    tree, frontier = {}, [pid]
    while frontier:
        found = [child for child, ppid in parent.items() if ppid in frontier]
        tree.update((child, name[child]) for child in found)
        frontier = found
    return tree


def arena_members(tree: dict[int, str]) -> dict[int, str]:
    """The arenas' own processes of a :func:`process_tree` (server, coach, players)."""
    return {pid: name for pid, name in tree.items() if not any(h in name for h in MULTIPROCESSING_HELPERS)}


def running(pids, timeout_s: float = 0.0) -> set[int]:
    """Those of ``pids`` still running (neither gone nor zombies) once they are all gone or
    ``timeout_s`` has passed."""
    deadline = time.monotonic() + timeout_s
    while True:
        left = set()
        for pid in pids:
            try:
                if "zombie" not in Path(f"/proc/{pid}/status").read_text():
                    left.add(pid)
            except OSError:
                continue
        if not left or time.monotonic() >= deadline:
            return left
        time.sleep(0.05)


def read_until_match(stream, pattern: re.Pattern, timeout_s: float) -> re.Match:
    """Read a child's pipe until ``pattern`` matches what it has said; TimeoutError after ``timeout_s``,
    EOFError if the child closes the pipe first. Reads the file descriptor behind a selector: a
    blocking readline would wait forever for a child that prints nothing."""
    seen = b""
    deadline = time.monotonic() + timeout_s
    with selectors.DefaultSelector() as selector:
        selector.register(stream, selectors.EVENT_READ)
        while not (match := pattern.search(seen.decode(errors="replace"))):
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not selector.select(remaining):
                raise TimeoutError(f"no {pattern.pattern!r} after {timeout_s:g} s; it said {seen[-500:]!r}")
            chunk = os.read(stream.fileno(), 65536)
            if not chunk:
                raise EOFError(f"it closed its output before {pattern.pattern!r}; it said {seen[-500:]!r}")
            seen += chunk
    return match


def _follow(path: Path, sink_fd: int, proc: subprocess.Popen) -> None:
    """Copy the stderr file ``path`` into the pipe ``sink_fd`` as ``proc`` writes it, until ``proc`` has
    exited and everything is copied (then the reader sees the end of the pipe), or until the reader
    closes its end."""
    try:
        with path.open("rb") as source:
            while True:
                exited = proc.poll() is not None  # before the read: all it wrote is in the file
                chunk = source.read(65536)
                if not chunk:
                    if exited:
                        return
                    time.sleep(FOLLOW_INTERVAL_S)
                while chunk:
                    chunk = chunk[os.write(sink_fd, chunk):]
    except BrokenPipeError:
        return
    finally:
        os.close(sink_fd)


def program_name(args: list[str]) -> str:
    """``server`` for ``python -m keepaway server ...``, else the executable's name."""
    return args[3] if args[1:3] == ["-m", "keepaway"] and len(args) > 3 else Path(args[0]).name


class ProcessGroup:
    """Every process a test starts, their stderr files in ``stderr_dir``; all the processes are killed
    at teardown, even when the test failed."""

    def __init__(self, stderr_dir: Path) -> None:
        self.stderr_dir = stderr_dir
        self.procs: list[subprocess.Popen] = []
        self.stderr_paths: dict[subprocess.Popen, Path] = {}
        self.followers: list[threading.Thread] = []

    def popen(self, args: list[str], **kwargs) -> subprocess.Popen:
        """Start ``args`` in a session of its own with its stderr going to a file (:meth:`stderr_path`).
        With ``stderr=subprocess.PIPE`` the caller still gets ``proc.stderr``, a pipe fed from that
        file: the child never waits for a reader."""
        stderr = kwargs.pop("stderr", None)
        piped = stderr == subprocess.PIPE
        path = self.stderr_dir / f"{len(self.procs):02d}-{program_name(args)}.stderr"
        with path.open("wb") as sink:
            proc = subprocess.Popen(args, cwd=kwargs.pop("cwd", REPO), start_new_session=True,
                                    stderr=sink if piped or stderr is None else stderr, **kwargs)
        self.procs.append(proc)
        self.stderr_paths[proc] = path
        if piped:
            read_end, write_end = os.pipe()
            text = bool(kwargs.get("text") or kwargs.get("universal_newlines") or kwargs.get("encoding"))
            proc.stderr = os.fdopen(read_end, "r" if text else "rb", encoding=kwargs.get("encoding"),
                                    errors=kwargs.get("errors"))
            follower = threading.Thread(target=_follow, args=(path, write_end, proc), daemon=True)
            follower.start()
            self.followers.append(follower)
        return proc

    def stderr_path(self, proc: subprocess.Popen) -> Path:
        return self.stderr_paths[proc]

    def stderr_tail(self, proc: subprocess.Popen) -> str:
        return self.stderr_path(proc).read_text(errors="replace")[-TAIL_CHARS:]

    def kill(self, proc: subprocess.Popen) -> None:
        """SIGKILL ``proc`` and everything it started (its session), and reap it."""
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait()

    def start_server(self, tmp_path: Path, *extra: str, start_timeout_s: float = START_TIMEOUT_S) -> ServerProcess:
        """A ``keepaway server -v`` on free ports, once it has announced them; a server that exits or
        stays silent for ``start_timeout_s`` is killed and the error shows the end of its stderr. Its
        log is in :meth:`ServerProcess.stderr_text` and, to wait for a line, in ``proc.stderr``."""
        log_dir = tmp_path / "logs"
        proc = self.popen(
            keepaway_command("server", "--players-port", "0", "--coach-port", "0", "--monitor-port", "0",
                             "--log-dir", str(log_dir), "-v", *extra),
            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            match = read_until_match(proc.stdout, LISTEN_RE, start_timeout_s)
        except (TimeoutError, EOFError) as exc:
            self.kill(proc)
            raise RuntimeError(f"server did not start: {exc}\n{self.stderr_tail(proc)}") from None
        host, p, c, mon, rcss = match.groups()
        return ServerProcess(proc, host, int(p), int(c), int(mon), log_dir, self.stderr_path(proc),
                             None if rcss is None else int(rcss))

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
        for follower in self.followers:
            follower.join(timeout=5)


@pytest.fixture
def processes(request, tmp_path_factory):
    """A :class:`ProcessGroup` whose stderr files sit in a directory of their own (not in ``tmp_path``,
    which a test may expect to hold only what the program under test wrote)."""
    group = ProcessGroup(tmp_path_factory.mktemp(re.sub(r"\W", "_", request.node.name)[:30] + "-stderr"))
    try:
        yield group
    finally:
        group.cleanup()


def pytest_sessionstart(session: pytest.Session) -> None:
    """Every numba kernel set compiled into the cache once, before any test starts processes: otherwise
    the first tests' server and five players would each compile the same kernels at once (``keepaway
    compile``; a no-op when this source's cache is already warm, as it is in every xdist worker, which the
    controller starts after this). Here and not in a fixture: a fixture's setup counts against the first
    test's timeout (pyproject's ``timeout``), and a clean checkout's cold compile takes minutes on the
    2-core machine (about 2 now, 5 at a slow hour before the kernels stopped being compiled twice: a fresh
    clone's CI run then had every test fail with the compile cut off at 300 s)."""
    if session.config.option.collectonly:
        return
    from keepaway.runner.kernels import KERNEL_SETS, CompileError, ensure_compiled

    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    try:
        ensure_compiled(KERNEL_SETS, announce=None if reporter is None else reporter.write_line)
    except CompileError as exc:
        pytest.exit(str(exc), returncode=pytest.ExitCode.INTERNAL_ERROR)


@pytest.fixture
def reference_stack():
    """The reference stack that tools/build-reference-stack.sh built into ``$KEEPAWAY_REFERENCE_STACK``
    (rcssserver 19.0.0 and the keepaway-0.6 C++ players; .ci/run builds it); the test says so and skips
    where it is not built."""
    sys.path.insert(0, str(REPO))
    from benchmarks.reference_stack import ReferenceStack

    build = os.environ.get("KEEPAWAY_REFERENCE_STACK")
    if not build:
        pytest.skip("the reference stack is not built here: set KEEPAWAY_REFERENCE_STACK to the directory "
                    "tools/build-reference-stack.sh built into (.ci/run does)")
    stack = ReferenceStack(Path(build))
    try:
        stack.check()
    except ValueError as exc:
        pytest.skip(str(exc))
    return stack
