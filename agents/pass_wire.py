"""The wire form of a keeper's Pass learner data in coach messages (docs/advice.md).

Two directions share one chunking mechanism (:func:`chunked`): the player's reports to the coach (SMDP
transitions, snapshots) and the coach's ``pass_load`` advice to a player, each chunk a message of
``protocol.advice``, which declares and checks them. Arrays travel as little-endian ``bin`` fields; a
message holds at most :data:`REPORT_BYTES` of per-entry array bytes, well below the 4 MiB message limit
(docs/protocol.md 1), so longer data is sent as ``chunks`` messages numbered ``chunk`` 0, 1, ..., each
carrying the same head fields and the entries ``first`` .. ``first + count - 1``.

The sparse Pass policy (:func:`sparse_pass_chunks`) is one keeper's SMDP Sarsa state as
``agents.sarsa.policy_arrays`` gives it (spec `keepaway-agents.md` 5: the weights and the collision table
that maps tiles to them; the C++ weights file holds the same): only the table's occupied slots (and any
slot with a non-zero weight) travel, as (``index``, ``check``, ``value``) triples in slot order, so the
dense arrays, and with them the exact learner, are rebuilt by :func:`pass_arrays_from_chunks`.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import numpy as np

from keepaway.agents.sarsa import EMPTY_SLOT, SarsaConfig
from keepaway.protocol.advice import ARRAY_DTYPES, HASH_COUNTS, SparsePassChunk
from keepaway.protocol.codec import Message

# Per-entry array bytes per message: well below the server's 4 MiB message limit (protocol.endpoints
# DEFAULT_MAX_MESSAGE_BYTES) once msgpack framing and the server's player_report envelope are added.
REPORT_BYTES = 1 << 20
_SPARSE_ENTRIES = ("index", "check", "value")


def _chunk_slices(n: int, entry_bytes: int) -> list[slice]:
    """Slices of ``n`` entries of ``entry_bytes`` each, at most :data:`REPORT_BYTES` per slice (one
    empty slice when ``n`` is 0)."""
    per_chunk = max(1, REPORT_BYTES // max(1, entry_bytes))
    return [slice(i, min(i + per_chunk, n)) for i in range(0, n, per_chunk)] or [slice(0, 0)]


def chunked(cls: type[Message], head: dict[str, Any], arrays: dict[str, np.ndarray], n: int,
            first: int = 0) -> list[Any]:
    """``arrays`` (``n`` entries each along the first axis, numbered from ``first``) as messages ``cls``
    (a ``protocol.advice.Chunk``) of at most :data:`REPORT_BYTES` array bytes: ``head``'s fields plus
    ``chunk``/``chunks``, ``first``/``count`` (the chunk's entries) and each array's slice, in its wire
    dtype (``protocol.advice.ARRAY_DTYPES``)."""
    wire = {name: np.ascontiguousarray(a, dtype=ARRAY_DTYPES[name]) for name, a in arrays.items()}
    entry_bytes = sum(a.nbytes // max(1, n) for a in wire.values())
    parts = _chunk_slices(n, entry_bytes)
    return [cls(**head, chunk=i, chunks=len(parts), first=first + part.start, count=part.stop - part.start,
                **{name: a[part] for name, a in wire.items()})
            for i, part in enumerate(parts)]


def sparse_pass_chunks(arrays: dict[str, np.ndarray], config: SarsaConfig, cls: type[SparsePassChunk],
                       **head: Any) -> list[Any]:
    """One keeper's Pass policy (``pass_weights``, ``pass_hash_check``, ``pass_hash_counts`` as
    ``agents.sarsa.policy_arrays`` gives them, learned with ``config``) as chunks ``cls``
    (``PassLoadAdvice`` or ``PassSnapshotReport``, whose other fields ``head`` gives): ``config`` (a plain
    map), ``table_size``, ``hash_counts`` and the occupied slots' ``index``/``check``/``value`` (module
    docstring). ValueError if the arrays do not fit ``config``."""
    weights = np.asarray(arrays["pass_weights"])
    check = np.asarray(arrays["pass_hash_check"])
    counts = np.asarray(arrays["pass_hash_counts"])
    size = config.table_size
    if weights.shape != (size,) or check.shape != (size,) or counts.shape != (HASH_COUNTS,):
        raise ValueError(f"Pass arrays of shapes {weights.shape}, {check.shape}, {counts.shape} do not fit "
                         f"table_size {size} (expected ({size},), ({size},), ({HASH_COUNTS},))")
    index = np.flatnonzero((check != EMPTY_SLOT) | (weights != 0.0))
    head = {**head, "config": asdict(config), "table_size": size,
            "hash_counts": np.ascontiguousarray(counts, dtype=ARRAY_DTYPES["hash_counts"])}
    return chunked(cls, head, {"index": index, "check": check[index], "value": weights[index]}, len(index))


def _ordered_chunks(chunks: list[Any]) -> list[Any]:
    """The chunks in order; ValueError on a duplicate, a missing chunk or disagreeing counts."""
    if not chunks:
        raise ValueError("no Pass chunks")
    by_chunk: dict[int, Any] = {}
    totals = set()
    for part in chunks:
        if part.chunk in by_chunk:
            raise ValueError(f"duplicate chunk {part.chunk}")
        by_chunk[part.chunk] = part
        totals.add(part.chunks)
    if len(totals) > 1:
        raise ValueError(f"the chunks disagree on their number: {sorted(totals)}")
    (total,) = totals
    missing = sorted(set(range(total)) - set(by_chunk))
    if missing:
        raise ValueError(f"missing chunks {missing} of {total}")
    return [by_chunk[i] for i in range(total)]


def pass_arrays_from_chunks(chunks: list[SparsePassChunk]) -> tuple[SarsaConfig, dict[str, np.ndarray]]:
    """The inverse of :func:`sparse_pass_chunks` (decoded chunks, in any order; each already checked on
    its own by ``protocol.advice``): the learner's config and the dense ``pass_weights`` /
    ``pass_hash_check`` / ``pass_hash_counts``. Raises ValueError (one line) on missing or duplicate
    chunks, a chunk without a policy (a report of a keeper without a learner), head fields that differ
    between chunks, entries that do not follow on, a config the learner refuses or a slot given twice."""
    parts = _ordered_chunks(chunks)
    head = parts[0]
    for i, part in enumerate(parts):
        if part.config is None:
            raise ValueError(f"chunk {i} holds no Pass policy (the keeper has no Sarsa learner)")
        if part.config != head.config or part.table_size != head.table_size:
            raise ValueError(f"chunk {i}'s config differs from chunk 0's")
        if not np.array_equal(part.hash_counts, head.hash_counts):
            raise ValueError(f"chunk {i}'s hash_counts differ from chunk 0's")
    try:
        config = SarsaConfig(**head.config)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"bad config: {' '.join(str(exc).split())}") from None
    total = 0
    for i, part in enumerate(parts):
        if part.first != total:
            raise ValueError(f"chunk {i} holds entries first={part.first} count={part.count}; expected first={total}")
        total += part.count
    index, check, value = (np.concatenate([getattr(part, name) for part in parts]) for name in _SPARSE_ENTRIES)
    if np.unique(index).size != index.size:
        raise ValueError("repeated slot indices")
    weights = np.zeros(config.table_size)
    hash_check = np.full(config.table_size, EMPTY_SLOT, dtype=np.int32)
    weights[index] = value
    hash_check[index] = check
    return config, {"pass_weights": weights, "pass_hash_check": hash_check,
                    "pass_hash_counts": np.asarray(head.hash_counts, dtype=np.int64)}


__all__ = ["REPORT_BYTES", "chunked", "pass_arrays_from_chunks", "sparse_pass_chunks"]
