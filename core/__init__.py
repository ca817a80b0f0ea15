"""What the simulation's numeric layers share below the protocol: the numba set-up (``core.jit``).

A leaf: it imports nothing of the project, so ``server``, ``agents`` and ``trainer`` can all build on it.
"""
