"""Where faultlab caches what it can compute again: the user's cache directory, never the source tree.

``$FAULTLAB_CACHE_DIR`` if set (an empty string disables the caches that can be disabled), else
``$XDG_CACHE_HOME/faultlab``, else ``~/.cache/faultlab``.  The screened mutants
(:mod:`faultlab.mutation.catalogue`) and the compiled kernels (:mod:`faultlab.slam.kernels`,
in ``numba/`` below it) are kept there.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

__all__ = ["cache_dir", "numba_cache_dir", "write_cache_json"]


def cache_dir() -> Path | None:
    """The cache directory; None if caching is disabled (``FAULTLAB_CACHE_DIR=""``)."""
    env = os.environ.get("FAULTLAB_CACHE_DIR")
    if env is not None:
        return Path(env) if env.strip() else None
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "faultlab"


def numba_cache_dir() -> Path:
    """Where numba keeps the compiled kernels: ``$NUMBA_CACHE_DIR`` if set, else ``numba/`` in
    :func:`cache_dir` (in the default user cache when caching is disabled: numba otherwise writes
    next to the package's source)."""
    env = os.environ.get("NUMBA_CACHE_DIR")
    if env:
        return Path(env)
    base = cache_dir()
    if base is None:
        base = Path(os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")) / "faultlab"
    return base / "numba"


def write_cache_json(path: Path, data) -> None:
    """Write ``data`` as JSON to ``path`` atomically (a temporary file renamed over it); a cache is an
    optimisation only, so a failure to write it (no room, no permission) is ignored."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=path.parent, suffix=".tmp", delete=False) as f:
            json.dump(data, f)
        os.replace(f.name, path)
    except OSError:
        pass
