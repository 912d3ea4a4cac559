"""On-disk cache of derivations, keyed by a hash of model, method and version.

Location: $SYMDYN_CACHE_DIR, else $XDG_CACHE_HOME/symdyn, else
~/.cache/symdyn.  An entry records its own key; a corrupt, truncated or
foreign entry is detected on load, reported, and rebuilt.  Writes are
atomic (temporary file, then rename).
"""

from __future__ import annotations

import hashlib
import os
import pickle
import sys
import tempfile
from pathlib import Path
from typing import Any, Callable

from sympy.core.parameters import evaluate

FORMAT = 1


def cache_dir() -> Path:
    """The directory that holds symdyn's cache entries."""
    if os.environ.get("SYMDYN_CACHE_DIR"):
        return Path(os.environ["SYMDYN_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "symdyn"


def key(*parts: str) -> str:
    """A hex key from text parts (model fingerprint, method, version, options)."""
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()


def write_atomic(path: Path, data: bytes) -> None:
    """Write bytes so that readers see the old file or the whole new one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def cached(kind: str, entry_key: str, build: Callable[[], Any], *, use_cache: bool = True) -> tuple[Any, bool]:
    """The value stored under (kind, key), or build() stored there; and
    whether it came from the cache."""
    path = cache_dir() / f"{kind}-{entry_key[:32]}.pickle"
    if use_cache and path.exists():
        try:
            # stored expressions are already canonical: rebuilding them without
            # re-evaluation gives equal objects three times faster
            with open(path, "rb") as fh, evaluate(False):
                stored = pickle.load(fh)
            if stored.get("format") == FORMAT and stored.get("key") == entry_key:
                return stored["value"], True
            reason = "it belongs to another model or symdyn version"
        except Exception as exc:  # noqa: BLE001 (any unreadable entry is rebuilt)
            reason = f"it is unreadable ({type(exc).__name__})"
        print(f"symdyn: cache entry {path} ignored: {reason}; rebuilding", file=sys.stderr)
    value = build()
    if use_cache:
        payload = pickle.dumps({"format": FORMAT, "key": entry_key, "value": value}, protocol=5)
        write_atomic(path, payload)
    return value, False
