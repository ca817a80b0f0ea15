"""Where Keepaway games are played for a learner or a user: every execution mode behind one interface.

``runner.job`` is the leaf: the value types of a job (the game, the policies, the episodes that come
back, the seeds) and the :class:`runner.job.Backend` protocol, "play N episodes of these policies in this
learning mode, from this seed". The backends implement it: batched (``runner.batched`` steps many arenas
in compiled kernels; ``runner.batched_backend``), embedded (``runner.embedded``: the server's arena and
the players' agents in this process) and distributed (``runner.distributed``: arenas of processes,
started by ``runner.launch``, placed on Ray by ``runner.ray_backend``), both of the latter fed by the same
chunks of coach requests (``runner.coached``); every backend plays a job's chunks (``runner.job.chunk_seeds``)
as fresh arenas of their seeds, so all three play the same games. ``runner.run`` is ``keepaway run``; ``runner.kernels``
compiles the numba kernels before processes load them.

The name: ``server.arena`` is one game's world and referee, ``protocol.arena`` the trainer's messages to
an arena's coach; this package runs arenas, in any mode, and knows nothing of learning. ``trainer``
builds on it (CEM, Sarsa phases, schedules, checkpoints, experiments) and it never imports ``trainer``.

Names are imported on first use (PEP 562), so loading the command line does not import numba.
"""

from __future__ import annotations

from keepaway.core.exports import lazy_exports

# The backends (above), here rather than in ``runner.job`` so that the command line can offer them
# without importing the players' kernels.
MODES = ("batched", "embedded", "distributed")

_EXPORTS = {
    "keepaway.runner.job": ("BATCHED_SARSA", "GREEDY", "LEARN", "LEARNED", "Backend", "Behaviours", "EpisodeTable",
                            "Game", "Played", "Progress", "RunResult", "chunk_seeds", "derive_seed"),
    "keepaway.runner.backends": ("Placement", "open_backend"),
    "keepaway.runner.batched": ("BatchedArenas",),
    "keepaway.runner.batched_backend": ("BatchedBackend",),
    "keepaway.runner.embedded": ("ArenaSpec", "EmbeddedBackend", "EmbeddedGame"),
    "keepaway.runner.distributed": ("DistributedBackend",),
    "keepaway.runner.launch": ("ArenaFailure", "ArenaProcesses"),
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = ["MODES", *__all__]
