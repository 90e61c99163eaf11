"""Reading TOML configuration files with one clear error per failure."""

from __future__ import annotations

import tomllib
from pathlib import Path

from faultlab.errors import ConfigError

__all__ = ["read_toml"]


def read_toml(path: str | Path, *, what: str) -> tuple[dict, str]:
    """Read and parse a TOML file.

    Parameters
    ----------
    path : str or Path
    what : str
        What the file is, for messages (e.g. ``"experiment file"``).

    Returns
    -------
    (dict, str)
        The parsed table and the file's text.

    Raises
    ------
    ConfigError
        ``"<path>: <what> cannot be read (...)"`` or ``"<path>: <what> is not valid TOML (...)"``.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"{p}: {what} cannot be read ({exc.strerror or exc})") from exc
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: {what} is not valid TOML ({exc})") from exc
