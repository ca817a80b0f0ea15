"""Policy files: a keeper's learned parameters on disk (``.npz``), read by ``keepaway player --policy``.

One ``.npz`` archive holds a JSON header and the parameter arrays:

* ``header``: UTF-8 JSON stored as a uint8 array (a str array is read too), ``{"format":
  "keepaway-policy", "version": 2, "config": {...}, "seed": ..., "created": ..., "getopen_inputs": ...}``
  (version 1 is read too); ``config`` is a free map in which ``keepers`` and ``takers`` (default 3 and 2;
  2-11 and 1-11) size the nets;
* ``getopen_theta`` (optional): the GO:L net parameters, ``net_size(3K + T - 1)`` floats (91 for 3v2;
  spec `keepaway-task.md` 4, layout in ``agents.getopen.net_value``), of the net on the inputs scaled by
  the header's ``getopen_inputs`` (version 2: ``{"mean": [...], "scale": [...]}``, one per input, the net
  sees (x - mean) / scale; ``agents.getopen.InputScaling``). A version 1 file has none: its net is on the
  raw variables (the identity), and plays as it did. :attr:`Policy.getopen_net` is the net with the
  scaling folded in, the form the kernels and the coach's advice take;
* ``pass_weights`` (optional): the Pass learner's weights, and any further ``pass_*`` arrays of its
  state (e.g. a hash table's bookkeeping); their shapes belong to the Sarsa learner (spec
  `keepaway-agents.md` 5), so they are only checked to be finite real numbers here. Each keeper learns
  its own Pass policy (spec `keepaway-agents.md` 5): keeper 1's arrays have the plain names, keeper k's
  (k >= 2) the names ``pass_keeper<k>_*`` (:func:`pack_pass_arrays`); a keeper without its own arrays uses
  the plain ones (:func:`keeper_pass_arrays`).

The archive is read without pickle. Whatever is wrong with a file (missing, not an archive, corrupt,
wrong header, wrong shape, NaN) is reported as one :class:`PolicyFileError` line naming the file.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from datetime import datetime, timezone
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from keepaway.agents.getopen import InputScaling, net_size
from keepaway.agents.state_vars import getopen_state_size
from keepaway.protocol.params import KEEPAWAY_KEEPERS, KEEPAWAY_TAKERS

POLICY_FORMAT = "keepaway-policy"
POLICY_VERSION = 2  # 2: the header records getopen_inputs
READABLE_VERSIONS = (1, 2)  # 1: GO:L nets on raw inputs
DEFAULT_KEEPERS = 3
DEFAULT_TAKERS = 2
TEAM_SIZES = {"keepers": KEEPAWAY_KEEPERS, "takers": KEEPAWAY_TAKERS}
NPY_MAGIC = b"\x93NUMPY"
PASS_PREFIX = "pass_"  # the Pass learner's arrays
KEEPER_PREFIX = "pass_keeper"  # keeper k's own Pass arrays: pass_keeper<k>_*
PASS_WEIGHTS = "pass_weights"


class PolicyFileError(Exception):
    """A policy file that cannot be used; ``str(exc)`` is one line naming the file and the problem."""


@dataclass(frozen=True)
class Policy:
    """The contents of a policy file (arrays are read-only; floats are float64)."""

    path: str
    config: dict[str, Any] = field(default_factory=dict)
    seed: int | None = None
    created: str | None = None
    getopen_theta: np.ndarray | None = None
    pass_arrays: dict[str, np.ndarray] = field(default_factory=dict)
    getopen_inputs: InputScaling | None = None  # the scaling getopen_theta's net sees its inputs through

    @property
    def getopen_net(self) -> np.ndarray | None:
        """The GO:L parameters on the raw state variables (the scaling folded in), what plays."""
        if self.getopen_theta is None or self.getopen_inputs is None:
            return self.getopen_theta
        return self.getopen_inputs.fold(self.getopen_theta)

    @property
    def pass_weights(self) -> np.ndarray | None:
        return self.pass_arrays.get(PASS_WEIGHTS)

    @property
    def n_keepers(self) -> int:
        return int(self.config.get("keepers", DEFAULT_KEEPERS))

    @property
    def n_takers(self) -> int:
        return int(self.config.get("takers", DEFAULT_TAKERS))


def getopen_theta_size(n_keepers: int = DEFAULT_KEEPERS, n_takers: int = DEFAULT_TAKERS) -> int:
    """Parameters of the GO:L net for K keepers and T takers: the (3K + T - 1)-5-5-1 net (91 for 3v2)."""
    return net_size(getopen_state_size(n_keepers, n_takers))


def as_getopen_theta(values: Any, size: int) -> np.ndarray:
    """``values`` as a read-only float64 GO:L parameter vector of length ``size``; ValueError (one line)
    if it is not ``size`` finite real numbers. Shared by the file reader and the coach's policy advice."""
    array = np.asarray(values)
    if array.dtype.kind not in "iuf":
        raise ValueError(f"getopen_theta must hold real numbers, not {array.dtype}")
    if array.shape != (size,):
        raise ValueError(f"getopen_theta has shape {array.shape}, expected ({size},)")
    return _finite(array.astype(np.float64), "getopen_theta")


def _finite(array: np.ndarray, name: str) -> np.ndarray:
    """A read-only copy of ``array`` (integers kept, floats as float64); ValueError if a value is NaN or
    infinite."""
    out = np.array(array, dtype=np.float64 if array.dtype.kind == "f" else array.dtype)
    bad = ~np.isfinite(out)
    if bad.any():
        raise ValueError(f"{name} has {int(bad.sum())} non-finite values (first at index "
                         f"{tuple(int(i) for i in np.argwhere(bad)[0])})")
    out.flags.writeable = False
    return out


def _pass_arrays(arrays: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """The Pass learner's arrays, checked: names ``pass_*`` including ``pass_weights``, each a non-empty
    array of finite real numbers."""
    bad_names = sorted(name for name in arrays if not name.startswith(PASS_PREFIX))
    if bad_names:
        raise ValueError(f"Pass arrays must be named {PASS_PREFIX}*, not {bad_names}")
    if PASS_WEIGHTS not in arrays:
        raise ValueError(f"Pass arrays {sorted(arrays)} lack {PASS_WEIGHTS}")
    out = {}
    for name, values in arrays.items():
        array = np.asarray(values)
        if array.dtype.kind not in "iuf":
            raise ValueError(f"{name} must hold real numbers, not {array.dtype}")
        if array.ndim == 0 or array.size == 0:
            raise ValueError(f"{name} has shape {array.shape}, expected a non-empty array")
        out[name] = _finite(array, name)
    return out


def pack_pass_arrays(keepers: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Every keeper's Pass policy as ``pass_*`` arrays of one policy file: keeper 1's under the plain
    names (``pass_weights``, ...), keeper k's as ``pass_keeper<k>_*``."""
    out = dict(keepers[0])
    for k, arrays in enumerate(keepers[1:], start=2):
        out.update({f"{KEEPER_PREFIX}{k}_{name.removeprefix(PASS_PREFIX)}": value for name, value in arrays.items()})
    return out


def keeper_pass_arrays(arrays: Mapping[str, np.ndarray], keeper: int) -> dict[str, np.ndarray]:
    """Keeper ``keeper``'s (uniform number) Pass arrays of a file packed by :func:`pack_pass_arrays`:
    its own ``pass_keeper<k>_*`` ones under the plain names, or the plain ones when it has none."""
    plain = {name: value for name, value in arrays.items() if not name.startswith(KEEPER_PREFIX)}
    prefix = f"{KEEPER_PREFIX}{keeper}_"
    own = {PASS_PREFIX + name.removeprefix(prefix): v for name, v in arrays.items() if name.startswith(prefix)}
    return own if keeper > 1 and own else plain


def unpack_pass_arrays(arrays: dict[str, np.ndarray], keepers: int) -> list[dict[str, np.ndarray]]:
    """The inverse of :func:`pack_pass_arrays`; a file with the plain names only gives every keeper the
    same policy."""
    return [keeper_pass_arrays(arrays, k) for k in range(1, keepers + 1)]


def _team_size(config: dict, name: str, default: int) -> int:
    value = config.get(name, default)
    if type(value) is not int or value not in TEAM_SIZES[name]:
        raise ValueError(f"config.{name} must be an integer in {TEAM_SIZES[name]}, not {value!r}")
    return value


def _header(raw: np.ndarray) -> dict:
    """The header map from its stored array (uint8 bytes of UTF-8 JSON, or a str scalar)."""
    if raw.dtype == np.uint8 and raw.ndim == 1:
        text = raw.tobytes().decode("utf-8")
    elif raw.dtype.kind == "U" and raw.ndim == 0:
        text = str(raw[()])
    else:
        raise ValueError(f"header is a {raw.dtype} array of shape {raw.shape}, expected uint8 JSON bytes")
    try:
        header = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"header is not JSON ({exc})") from None
    if type(header) is not dict:
        raise ValueError("header is not a JSON object")
    if header.get("format") != POLICY_FORMAT:
        raise ValueError(f"header format is {header.get('format')!r}, expected {POLICY_FORMAT!r}")
    if header.get("version") not in READABLE_VERSIONS:
        raise ValueError(f"policy file version {header.get('version')!r} is not supported "
                         f"(this program reads versions {', '.join(map(str, READABLE_VERSIONS))})")
    config = header.get("config", {})
    if type(config) is not dict:
        raise ValueError("header config is not a JSON object")
    seed = header.get("seed")
    if seed is not None and type(seed) is not int:
        raise ValueError(f"header seed must be an integer or null, not {seed!r}")
    return header


def read_npz(path: Path) -> dict[str, np.ndarray]:
    """Every array of the ``.npz`` archive ``path``, read eagerly and without pickle (a corrupt member
    fails here, not later). Anything else (another kind of file, a truncated or damaged archive, object
    arrays) is a ValueError saying why in one line, without the path; OSError if it cannot be read."""
    if not zipfile.is_zipfile(path):
        with open(path, "rb") as fh:
            single = fh.read(len(NPY_MAGIC)) == NPY_MAGIC
        raise ValueError("a single .npy array, not an .npz archive" if single
                         else "not an .npz archive: another kind of file, or a truncated one")
    try:
        with np.load(path, allow_pickle=False) as loaded:
            return {name: loaded[name] for name in loaded.files}
    except (ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise ValueError(" ".join(str(exc).split()) or type(exc).__name__) from None


def load_policy(path: str | Path) -> Policy:
    """Read and check a policy file; raises :class:`PolicyFileError` (one line) for any problem."""
    where = str(path)
    file = Path(path)
    if file.is_dir():
        raise PolicyFileError(f"{where}: a directory, not a policy file")
    if not file.is_file():
        raise PolicyFileError(f"{where}: no such policy file")
    try:
        arrays = read_npz(file)
    except (OSError, ValueError) as exc:
        raise PolicyFileError(f"{where}: not a readable policy archive ({' '.join(str(exc).split())})") from None
    try:
        if "header" not in arrays:
            held = ", ".join(sorted(arrays)) or "nothing"
            raise ValueError(f"not a keepaway policy file: no header array (it holds {held})")
        unknown = sorted(n for n in arrays if n not in ("header", "getopen_theta") and not n.startswith(PASS_PREFIX))
        if unknown:
            raise ValueError(f"unexpected arrays {unknown} (expected header, getopen_theta, {PASS_PREFIX}*)")
        header = _header(arrays["header"])
        config = header.get("config", {})
        keepers = _team_size(config, "keepers", DEFAULT_KEEPERS)
        takers = _team_size(config, "takers", DEFAULT_TAKERS)
        theta = arrays.get("getopen_theta")
        if theta is not None:
            theta = as_getopen_theta(theta, getopen_theta_size(keepers, takers))
        inputs = _getopen_inputs(header, getopen_state_size(keepers, takers), theta is not None)
        passes = {name: a for name, a in arrays.items() if name.startswith(PASS_PREFIX)}
        if passes:
            passes = _pass_arrays(passes)
    except (ValueError, UnicodeDecodeError) as exc:
        raise PolicyFileError(f"{where}: {' '.join(str(exc).split())}") from None
    return Policy(path=where, config=config, seed=header.get("seed"), created=header.get("created"),
                  getopen_theta=theta, pass_arrays=passes, getopen_inputs=inputs)


def _getopen_inputs(header: dict, n_inputs: int, has_net: bool) -> InputScaling | None:
    """The input scaling of the file's GO:L net (None without one): the header's ``getopen_inputs``; in a
    version 1 file, which has none, the identity (its net is on the raw variables)."""
    data = header.get("getopen_inputs")
    if not has_net:
        if data is not None:
            raise ValueError("header getopen_inputs without a getopen_theta array")
        return None
    if data is None:
        if header["version"] != 1:
            raise ValueError(f"header has no getopen_inputs for getopen_theta (version {header['version']} "
                             "records the net's input scaling)")
        return InputScaling.identity(n_inputs)
    return InputScaling.from_json(data, n_inputs)


def save_policy(
    path: str | Path,
    *,
    getopen_theta: Any = None,
    pass_arrays: Mapping[str, Any] | None = None,
    config: dict[str, Any] | None = None,
    seed: int | None = None,
    getopen_inputs: InputScaling | None = None,
) -> Path:
    """Write a policy file that :func:`load_policy` accepts (the same checks run before writing, so a
    bad policy is refused here with ValueError). ``pass_arrays`` is the Pass learner's state, at least
    ``{"pass_weights": ...}``; ``getopen_inputs`` the scaling ``getopen_theta``'s net sees its inputs
    through (default: the identity, a net on the raw variables). Returns the path written (``.npz``
    appended if absent, as numpy does)."""
    config = dict(config or {})
    keepers = _team_size(config, "keepers", DEFAULT_KEEPERS)
    takers = _team_size(config, "takers", DEFAULT_TAKERS)
    header = {"format": POLICY_FORMAT, "version": POLICY_VERSION, "config": config, "seed": seed,
              "created": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    n_inputs = getopen_state_size(keepers, takers)
    if getopen_theta is not None:
        inputs = getopen_inputs or InputScaling.identity(n_inputs)
        if inputs.n_inputs != n_inputs:
            raise ValueError(f"getopen_inputs scale {inputs.n_inputs} inputs, the net has {n_inputs}")
        header["getopen_inputs"] = inputs.to_json()
    elif getopen_inputs is not None:
        raise ValueError("getopen_inputs without getopen_theta")
    arrays: dict[str, np.ndarray] = {
        "header": np.frombuffer(json.dumps(header).encode("utf-8"), dtype=np.uint8)
    }
    if getopen_theta is not None:
        arrays["getopen_theta"] = as_getopen_theta(getopen_theta, getopen_theta_size(keepers, takers))
    if pass_arrays:
        arrays.update(_pass_arrays(pass_arrays))
    out = Path(path)
    if out.suffix != ".npz":
        out = out.with_name(out.name + ".npz")
    np.savez(out, **arrays)
    return out


__all__ = [
    "PASS_WEIGHTS",
    "POLICY_FORMAT",
    "POLICY_VERSION",
    "READABLE_VERSIONS",
    "Policy",
    "PolicyFileError",
    "as_getopen_theta",
    "getopen_theta_size",
    "keeper_pass_arrays",
    "load_policy",
    "pack_pass_arrays",
    "read_npz",
    "save_policy",
    "unpack_pass_arrays",
]
