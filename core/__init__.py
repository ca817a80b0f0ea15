"""What the layers above share below the protocol: the numba set-up (``core.jit``), lazy package
exports (``core.exports``), the rate-limited log the server and the coach both keep (``core.log_limit``),
the exit code of an interrupted command (``core.exits``) and the option types every command shares
(``core.options``).

A leaf: it imports nothing of the project, so ``server``, ``agents``, ``runner`` and ``trainer`` can all
build on it.
"""
