"""Imported by the players' fork server (``runner.launch``) before it forks any player: the player's
modules, and its compiled kernels loaded from numba's cache, once for every player the launcher starts.

A failure here must not stop the fork server (it would take every player with it): the players then
load their kernels themselves, as a started player does, and report what is wrong in their own logs.
"""

try:
    from keepaway.agents.player import compile_kernels

    compile_kernels()
except Exception:  # noqa: BLE001 - see the module docstring; the players meet the same error and report it
    pass
