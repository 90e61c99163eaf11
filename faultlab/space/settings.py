"""What a space file says besides its classes for two suite builders: base classes and class weights.

*Base classes* (``base-choice`` suite): the class of every parameter in the base case.  By default
the class of the *fixed* suite's value (:data:`~faultlab.space.case.FIXED_VALUES`); a space file
overrides some of them::

    [base]
    map_size = "small"
    bias = "low_pos"

*Class weights* (``effect-guided`` suite): how often each class of a parameter is chosen once
every class has been covered, relative to the parameter's other classes.  A parameter that is
listed gives a weight (finite, >= 0, not all zero) to every one of its classes; a parameter that
is not listed gets equal weights::

    [weights]
    inactivity = { none = 1.0, inactive = 3.0 }
    map_size = { small = 0.2, medium = 0.3, large = 0.5 }

The same weights as a CSV file (``--weights`` of ``faultlab generate``) have the columns
``parameter, class, weight``, one row per class.  :func:`weights_from_effects` turns estimated
per-class detection rates or odds ratios of an earlier campaign into such a table.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from faultlab.errors import ConfigError

__all__ = ["parse_base", "parse_weights", "read_class_weights", "weights_from_effects", "weights_frame"]


def _parameter(name: Any, by_name: Mapping, where: str, order: Sequence[str]):
    if name not in by_name:
        raise ConfigError(f"{where}: unknown parameter (known: {', '.join(order)})")
    return by_name[name]


def parse_base(raw: Any, parameters: Sequence, *, source: str) -> tuple[tuple[str, str], ...]:
    """The ``[base]`` table: parameter -> class name, in parameter order.

    Raises
    ------
    ConfigError
        Not a table, an unknown parameter or class, a class name that is not a string.
    """
    where = f"{source}: [base]"
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{where}: expected a table parameter = \"class\", got {type(raw).__name__}")
    by_name = {p.name: p for p in parameters}
    order = [p.name for p in parameters]
    for name, cls in raw.items():
        p = _parameter(name, by_name, f"{where}.{name}", order)
        if not isinstance(cls, str) or cls not in p.class_names:
            raise ConfigError(f"{where}.{name}: unknown class {cls!r} (classes: {', '.join(p.class_names)})")
    return tuple((p, raw[p]) for p in order if p in raw)


def parse_weights(raw: Any, parameters: Sequence, *, source: str,
                  table: str = "[weights]") -> tuple[tuple[str, tuple[float, ...]], ...]:
    """Class weights, ``{parameter: {class: weight}}``, as (parameter, weights in class order).

    Parameters
    ----------
    raw : mapping
    parameters : sequence of Parameter
    source : str
        The file, for messages.
    table : str
        How the weights are named in messages (``[weights]`` in a space file, ``""`` for a CSV file).

    Raises
    ------
    ConfigError
        An unknown parameter or class, a class without a weight, a weight that is not a finite
        number >= 0, a parameter whose weights are all zero.
    """
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{source}: {table or 'weights'}: expected a table parameter = "
                          f"{{ class = weight, ... }}, got {type(raw).__name__}")
    by_name = {p.name: p for p in parameters}
    order = [p.name for p in parameters]
    out = {}
    for name, ws in raw.items():
        wp = f"{source}: {table}.{name}" if table else f"{source}: {name}"
        p = _parameter(name, by_name, wp, order)
        if not isinstance(ws, Mapping):
            raise ConfigError(f"{wp}: expected a table class = weight, got {type(ws).__name__}")
        for cls in ws:
            if cls not in p.class_names:
                raise ConfigError(f"{wp}.{cls}: unknown class (classes: {', '.join(p.class_names)})")
        missing = [c for c in p.class_names if c not in ws]
        if missing:
            raise ConfigError(f"{wp}: no weight for class {missing[0]!r} (give every class of a listed "
                              f"parameter a weight)")
        vals = []
        for cls in p.class_names:
            w = ws[cls]
            if isinstance(w, bool) or not isinstance(w, (int, float)) or not math.isfinite(w) or w < 0:
                raise ConfigError(f"{wp}.{cls}: a weight must be a finite number >= 0, got {w!r}")
            vals.append(float(w))
        if not any(v > 0 for v in vals):
            raise ConfigError(f"{wp}: every weight is zero (at least one class needs a positive weight)")
        out[name] = tuple(vals)
    return tuple((p, out[p]) for p in order if p in out)


def read_class_weights(path: str | Path) -> dict[str, dict[str, float]]:
    """Read class weights from a CSV file with the columns ``parameter, class, weight``.

    Returns
    -------
    dict
        ``{parameter: {class: weight}}``; checked against a space by
        :meth:`~faultlab.space.parameters.ParameterSpace.with_weights`.

    Raises
    ------
    ConfigError
        Missing file or columns, a repeated (parameter, class) row, a weight that is not a number.
    """
    p = Path(path)
    try:
        df = pd.read_csv(p, dtype={"parameter": str, "class": str})
    except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise ConfigError(f"{p}: class-weights file cannot be read ({exc})") from exc
    missing = [c for c in ("parameter", "class", "weight") if c not in df.columns]
    if missing:
        raise ConfigError(f"{p}: class-weights file lacks the column {missing[0]!r} "
                          f"(expected parameter, class, weight)")
    out: dict[str, dict[str, float]] = {}
    for i, (par, cls, w) in enumerate(zip(df["parameter"], df["class"], df["weight"]), start=2):
        try:
            w = float(w)
        except (TypeError, ValueError):
            raise ConfigError(f"{p}: line {i}: weight {w!r} is not a number") from None
        if cls in out.setdefault(par, {}):
            raise ConfigError(f"{p}: line {i}: a second weight for {par} = {cls!r}")
        out[par][cls] = w
    return out


def weights_frame(weights: Mapping[str, Mapping[str, float]]) -> pd.DataFrame:
    """``{parameter: {class: weight}}`` as a table with the columns ``parameter, class, weight``."""
    return pd.DataFrame([{"parameter": p, "class": c, "weight": float(w)}
                         for p, ws in weights.items() for c, w in ws.items()],
                        columns=["parameter", "class", "weight"])


def weights_from_effects(effects: pd.DataFrame, *, floor: float = 0.05) -> pd.DataFrame:
    """Class weights proportional to the estimated detection probability, with a floor.

    Parameters
    ----------
    effects : DataFrame
        One row per (parameter, class) with the columns ``parameter``, ``class`` and one of

        - ``detection_rate``: estimated probability in [0, 1] that a case of this class detects
          the fault(s) of interest (e.g. the share of detecting cases in an earlier campaign);
        - ``odds_ratio``: estimated odds ratio (> 0) of detection for this class against any
          reference class of the same parameter; the detection odds, and for rare detection
          the probability, are then proportional to it.

        Only the classes of one parameter are compared with each other.
    floor : float
        Smallest weight a class gets, as a share of its parameter (``0 <= floor * n_classes <= 1``):
        the shares ``s`` (rates or odds ratios normalised within the parameter) become
        ``(1 - n * floor) * s + floor``, so no class is left out while the order is kept.
        A parameter whose rates are all zero gets equal weights.

    Returns
    -------
    DataFrame
        Columns ``parameter, class, weight``; the weights of a parameter sum to 1.

    Raises
    ------
    ConfigError
        Missing columns, both or neither of the estimate columns, values out of range, a floor
        too large for a parameter.
    """
    for col in ("parameter", "class"):
        if col not in effects.columns:
            raise ConfigError(f"weights_from_effects: the table lacks the column {col!r}")
    have = [c for c in ("detection_rate", "odds_ratio") if c in effects.columns]
    if len(have) != 1:
        raise ConfigError("weights_from_effects: give exactly one of the columns 'detection_rate' "
                          f"and 'odds_ratio' (found {', '.join(have) or 'neither'})")
    col = have[0]
    x = pd.to_numeric(effects[col], errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(x) | (x < 0) | ((x > 1) if col == "detection_rate" else (x <= 0))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        rng = "[0, 1]" if col == "detection_rate" else "(0, inf)"
        raise ConfigError(f"weights_from_effects: row {i}: {col} = {effects[col].iloc[i]} is not in {rng}")
    if effects.duplicated(["parameter", "class"]).any():
        raise ConfigError("weights_from_effects: a (parameter, class) appears twice")
    if not 0.0 <= floor:
        raise ConfigError(f"weights_from_effects: floor must be >= 0, got {floor}")
    frame = effects[["parameter", "class"]].copy()
    frame["x"] = x
    out = []
    for par, g in frame.groupby("parameter", sort=False):
        n = len(g)
        if floor * n > 1.0 + 1e-12:
            raise ConfigError(f"weights_from_effects: floor {floor} is too large for {par} "
                              f"({n} classes: floor * classes must be <= 1)")
        total = g["x"].sum()
        share = g["x"] / total if total > 0 else pd.Series(1.0 / n, index=g.index)
        w = (1.0 - n * floor) * share + floor
        out.append(pd.DataFrame({"parameter": par, "class": g["class"], "weight": w / w.sum()}))
    return pd.concat(out, ignore_index=True) if out else weights_frame({})
