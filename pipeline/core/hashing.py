"""Content hashes of inputs, for artifact reuse."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np


def _default(obj: Any):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot hash object of type {type(obj).__name__}")


def content_hash(payload: Any, files: tuple[Path, ...] = ()) -> str:
    """SHA-256 hex digest of a JSON-serialisable ``payload`` and the bytes of ``files``."""
    h = hashlib.sha256()
    h.update(json.dumps(payload, sort_keys=True, default=_default).encode())
    for f in files:
        h.update(Path(f).read_bytes())
    return h.hexdigest()
