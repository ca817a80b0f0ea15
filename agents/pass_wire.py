"""The wire form of a keeper's Pass learner data in coach messages (docs/advice.md).

Two directions share one chunking mechanism (:func:`chunked_payloads`): the player's ``report`` payloads
to the coach (SMDP transitions, snapshots) and the coach's ``pass_load`` advice to a player. Arrays travel
as little-endian ``bin`` fields (:data:`WIRE_DTYPES`); a message holds at most :data:`REPORT_BYTES` of
per-entry array bytes, well below the 4 MiB message limit (docs/protocol.md 1), so longer data is sent
as ``chunks`` payloads numbered ``chunk`` 0, 1, ..., each carrying the same head fields and the entries
``first`` .. ``first + count - 1``.

The sparse Pass policy (:func:`sparse_pass_payloads`) is one keeper's SMDP Sarsa state as
``agents.sarsa.policy_arrays`` gives it (spec `keepaway-agents.md` 5: the weights and the collision table
that maps tiles to them; the C++ weights file holds the same): only the table's occupied slots (and any
slot with a non-zero weight) travel, as (``index``, ``check``, ``value``) triples in slot order, so the
dense arrays, and with them the exact learner, are rebuilt by :func:`pass_arrays_from_payloads`.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import numpy as np

from agents.sarsa import EMPTY_SLOT, SarsaConfig

# Per-entry array bytes per message: well below the server's 4 MiB message limit (protocol.endpoints
# DEFAULT_MAX_MESSAGE_BYTES) once msgpack framing and the server's player_report envelope are added.
REPORT_BYTES = 1 << 20
# Wire dtypes of the byte fields (little-endian; actions fit in int8, slot indices in uint32, the
# collision table's check values in int32).
WIRE_DTYPES = {"state": "<f8", "action": "<i1", "reward": "<f8", "next_action": "<i1", "terminal": "<u1",
               "index": "<u4", "check": "<i4", "value": "<f8", "hash_counts": "<i8"}
HASH_COUNTS = 3  # agents.sarsa.SarsaMemory.hash_counts columns
_SPARSE_ENTRIES = ("index", "check", "value")
_SAME_IN_EVERY_CHUNK = ("config", "table_size", "hash_counts")


def _chunk_slices(n: int, entry_bytes: int) -> list[slice]:
    """Slices of ``n`` entries of ``entry_bytes`` each, at most :data:`REPORT_BYTES` per slice (one
    empty slice when ``n`` is 0)."""
    per_chunk = max(1, REPORT_BYTES // max(1, entry_bytes))
    return [slice(i, min(i + per_chunk, n)) for i in range(0, n, per_chunk)] or [slice(0, 0)]


def chunked_payloads(head: dict[str, Any], arrays: dict[str, np.ndarray], n: int,
                     first: int = 0) -> list[dict[str, Any]]:
    """``arrays`` (``n`` entries each along the first axis, numbered from ``first``) as payloads of at
    most :data:`REPORT_BYTES` array bytes: ``head`` plus ``chunk``/``chunks``, ``first``/``count`` (the
    chunk's entries) and each array as little-endian bytes (:data:`WIRE_DTYPES`)."""
    wire = {name: np.ascontiguousarray(a, dtype=WIRE_DTYPES[name]) for name, a in arrays.items()}
    entry_bytes = sum(a.nbytes // max(1, n) for a in wire.values())
    parts = _chunk_slices(n, entry_bytes)
    return [{**head, "chunk": i, "chunks": len(parts), "first": first + part.start,
             "count": part.stop - part.start, **{name: a[part].tobytes() for name, a in wire.items()}}
            for i, part in enumerate(parts)]


def report_arrays(payload: dict[str, Any]) -> dict[str, Any]:
    """A payload of :func:`chunked_payloads` with its byte fields as numpy arrays (transition states
    reshaped to (count, n_vars), ``terminal`` as bool); the other fields unchanged."""
    out = dict(payload)
    for name, dtype in WIRE_DTYPES.items():
        if name in out:
            out[name] = np.frombuffer(out[name], dtype=dtype)
    if "state" in out:
        out["state"] = out["state"].reshape(payload["count"], payload["n_vars"])
        out["terminal"] = out["terminal"].astype(bool)
    return out


def chunk_position(payload: Any) -> tuple[int, int]:
    """``(chunk, chunks)`` of a chunked payload; ValueError (one line) unless they are integers with
    0 <= chunk < chunks."""
    if type(payload) is not dict:
        raise ValueError(f"a chunk must be a map, not {type(payload).__name__}")
    chunk, chunks = payload.get("chunk"), payload.get("chunks")
    if type(chunk) is not int or type(chunks) is not int or not 0 <= chunk < chunks:
        raise ValueError(f"chunk {chunk!r} of {chunks!r} is not an integer 0 <= chunk < chunks")
    return chunk, chunks


def sparse_pass_payloads(arrays: dict[str, np.ndarray], config: SarsaConfig,
                         head: dict[str, Any]) -> list[dict[str, Any]]:
    """One keeper's Pass policy (``pass_weights``, ``pass_hash_check``, ``pass_hash_counts`` as
    ``agents.sarsa.policy_arrays`` gives them, learned with ``config``) as chunked payloads: ``head`` plus
    ``config`` (a plain map), ``table_size``, ``hash_counts`` (bytes <i8 x3) and the occupied slots'
    ``index``/``check``/``value`` (module docstring). ValueError if the arrays do not fit ``config``."""
    weights = np.asarray(arrays["pass_weights"])
    check = np.asarray(arrays["pass_hash_check"])
    counts = np.asarray(arrays["pass_hash_counts"])
    size = config.table_size
    if weights.shape != (size,) or check.shape != (size,) or counts.shape != (HASH_COUNTS,):
        raise ValueError(f"Pass arrays of shapes {weights.shape}, {check.shape}, {counts.shape} do not fit "
                         f"table_size {size} (expected ({size},), ({size},), ({HASH_COUNTS},))")
    index = np.flatnonzero((check != EMPTY_SLOT) | (weights != 0.0))
    head = {**head, "config": asdict(config), "table_size": size,
            "hash_counts": np.ascontiguousarray(counts, dtype=WIRE_DTYPES["hash_counts"]).tobytes()}
    return chunked_payloads(head, {"index": index, "check": check[index], "value": weights[index]}, len(index))


def _bytes_field(part: dict[str, Any], name: str, i: int, count: int) -> np.ndarray:
    """Byte field ``name`` of chunk ``i`` as its array of ``count`` entries."""
    raw = part.get(name)
    dtype = np.dtype(WIRE_DTYPES[name])
    if type(raw) is not bytes or len(raw) != count * dtype.itemsize:
        size = f"{len(raw)} bytes" if type(raw) is bytes else type(raw).__name__
        raise ValueError(f"chunk {i}: {name} is {size}, expected {count * dtype.itemsize} bytes")
    return np.frombuffer(raw, dtype=dtype)


def _ordered_chunks(payloads: list[Any]) -> list[dict[str, Any]]:
    """The payloads in chunk order; ValueError on a duplicate, a missing chunk or disagreeing counts."""
    if not payloads:
        raise ValueError("no Pass payloads")
    by_chunk: dict[int, dict[str, Any]] = {}
    totals = set()
    for payload in payloads:
        chunk, chunks = chunk_position(payload)
        if chunk in by_chunk:
            raise ValueError(f"duplicate chunk {chunk}")
        by_chunk[chunk] = payload
        totals.add(chunks)
    if len(totals) > 1:
        raise ValueError(f"the chunks disagree on their number: {sorted(totals)}")
    (chunks,) = totals
    missing = sorted(set(range(chunks)) - set(by_chunk))
    if missing:
        raise ValueError(f"missing chunks {missing} of {chunks}")
    return [by_chunk[i] for i in range(chunks)]


def pass_arrays_from_payloads(payloads: list[dict[str, Any]]) -> tuple[SarsaConfig, dict[str, np.ndarray]]:
    """The inverse of :func:`sparse_pass_payloads` (chunks in any order): the learner's config and the dense
    ``pass_weights`` / ``pass_hash_check`` / ``pass_hash_counts``. Raises ValueError (one line) on missing
    or duplicate chunks, head fields that differ between chunks, sizes that do not add up, slot indices
    out of the table or repeated, or non-finite weights."""
    parts = _ordered_chunks(payloads)
    head = parts[0]
    for i, part in enumerate(parts):
        for name in _SAME_IN_EVERY_CHUNK:
            if name not in part:
                raise ValueError(f"chunk {i} lacks {name}")
            if part[name] != head[name]:
                raise ValueError(f"chunk {i}'s {name} differs from chunk 0's")
    if type(head["config"]) is not dict:
        raise ValueError(f"config must be a map, not {type(head['config']).__name__}")
    try:
        config = SarsaConfig(**head["config"])
    except (TypeError, ValueError) as exc:
        raise ValueError(f"bad config: {' '.join(str(exc).split())}") from None
    if config.table_size > np.iinfo(WIRE_DTYPES["index"]).max + 1:
        raise ValueError(f"table_size {config.table_size} exceeds the uint32 slot indices")
    if head["table_size"] != config.table_size:
        raise ValueError(f"table_size {head['table_size']!r} is not the config's {config.table_size}")
    counts = _bytes_field(head, "hash_counts", 0, HASH_COUNTS)
    entries: dict[str, list[np.ndarray]] = {name: [] for name in _SPARSE_ENTRIES}
    total = 0
    for i, part in enumerate(parts):
        first, count = part.get("first"), part.get("count")
        if type(first) is not int or type(count) is not int or count < 0 or first != total:
            raise ValueError(f"chunk {i} holds entries first={first!r} count={count!r}; expected first={total}")
        for name in _SPARSE_ENTRIES:
            entries[name].append(_bytes_field(part, name, i, count))
        total += count
    index, check, value = (np.concatenate(entries[name]) for name in _SPARSE_ENTRIES)
    if index.size and int(index.max()) >= config.table_size:
        raise ValueError(f"slot index {int(index.max())} is outside the table of {config.table_size}")
    if np.unique(index).size != index.size:
        raise ValueError("repeated slot indices")
    if not np.isfinite(value).all():
        raise ValueError(f"{int((~np.isfinite(value)).sum())} non-finite weights")
    weights = np.zeros(config.table_size)
    hash_check = np.full(config.table_size, EMPTY_SLOT, dtype=np.int32)
    weights[index] = value
    hash_check[index] = check
    return config, {"pass_weights": weights, "pass_hash_check": hash_check,
                    "pass_hash_counts": counts.astype(np.int64)}


__all__ = [
    "REPORT_BYTES",
    "WIRE_DTYPES",
    "chunk_position",
    "chunked_payloads",
    "pass_arrays_from_payloads",
    "report_arrays",
    "sparse_pass_payloads",
]
