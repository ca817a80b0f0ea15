"""What the player's two socket edges share: the ZeroMQ one on our server (``agents/cli.py``) and the UDP
one on rcssserver (``agents/rcss_client.py``). Both end alike (exit codes, one stderr line), stop alike
on a signal, and count a server's silence alike (docs/design.md, "Processes and sockets")."""

from __future__ import annotations

import signal
from typing import Any

EXIT_OK = 0
EXIT_START_FAILED = 2
EXIT_SERVER_SILENT = 4
POLL_MS = 100  # longest wait between checks of the stop flag and the connect deadline (receive timeout)
# The most one empty receive adds to the server's silence: a receive that took longer was held up by the
# player's own process (frozen by SIGSTOP, starved of CPU), not by the server.
MAX_SILENT_WAIT_S = 2 * POLL_MS / 1000
# Between two ``reconnect``s refused because the seat is not free yet. Our server gives a hung player up
# after max_missed_cycles cycle timeouts (20 x 1.25 s by default, within --connect-timeout's default 60 s);
# asking once a second costs the server one probe of the old client a second.
RECONNECT_RETRY_S = 1.0


class PlayerExit(Exception):
    """Ends the player with ``code``; a non-empty ``message`` is printed as one stderr line."""

    def __init__(self, code: int, message: str = "") -> None:
        super().__init__(message)
        self.code = code
        self.message = message


class StopFlag:
    """The SIGTERM/SIGINT handler. Before the socket loop runs (loading the policy, compiling the
    kernels) there is nobody to say bye to: the player ends at once, with exit code 0. In the loop the
    signal only sets the flag, which the loop checks between polls."""

    def __init__(self) -> None:
        self.signal_name: str | None = None
        self.in_loop = False

    def __call__(self, signum: int, _frame: Any) -> None:
        self.signal_name = signal.Signals(signum).name
        if not self.in_loop:
            raise PlayerExit(EXIT_OK)
