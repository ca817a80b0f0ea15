"""What the layers above share below the protocol: the numba set-up (``core.jit``) and lazy package
exports (``core.exports``).

A leaf: it imports nothing of the project, so ``server``, ``agents``, ``runner`` and ``trainer`` can all
build on it.
"""
