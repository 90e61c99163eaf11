"""Analyses saved as one CSV per table plus a JSON file of metadata (mutation, study, fidelity, ablation).

A frozen dataclass whose fields are its tables (DataFrames, named in ``TABLES``) and its metadata
inherits :class:`TableBundle`: ``table(name)``, ``save(directory)`` and ``load(directory)``, with the
metadata in ``META_FILE``.  The metadata is the field ``meta`` (a dict), or, when the subclass
names them in ``META_FIELDS`` (field -> the type a loaded value is converted to), those scalar
fields.  A table with a :class:`~faultlab.analysis.schema.TableSchema` in ``SCHEMAS`` is written
and read by its schema
(:meth:`~faultlab.analysis.schema.TableSchema.to_csv`, ``read_csv``), so it loads back exactly.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Callable, ClassVar, Mapping

import pandas as pd

from faultlab.analysis.schema import TableSchema
from faultlab.errors import ResultsError
from faultlab.precision import write_csv

__all__ = ["TableBundle"]


class TableBundle:
    """Mixin: tables by name, saved as CSV files and metadata as ``META_FILE``."""

    TABLES: ClassVar[tuple[str, ...]] = ()
    META_FILE: ClassVar[str] = "meta.json"
    WHAT: ClassVar[str] = "analysis"
    SCHEMAS: ClassVar[tuple[TableSchema, ...]] = ()
    #: Scalar fields saved as the metadata, each with the type its saved value is read back as;
    #: empty: the metadata is the field ``meta``.
    META_FIELDS: ClassVar[Mapping[str, Callable]] = {}

    def saved_meta(self) -> dict:
        """The metadata :meth:`save` writes to ``META_FILE``: the ``META_FIELDS``, or the field ``meta``."""
        return {name: getattr(self, name) for name in self.META_FIELDS} if self.META_FIELDS else self.meta

    @classmethod
    def _schema(cls, name: str) -> TableSchema | None:
        return next((s for s in cls.SCHEMAS if s.name == name), None)

    def table(self, name: str) -> pd.DataFrame:
        if name not in self.TABLES:
            raise ResultsError(f"unknown {self.WHAT} table {name!r}; known: {', '.join(self.TABLES)}")
        return getattr(self, name)

    def save(self, directory: str | Path) -> Path:
        """Write every table and the metadata into ``directory`` (created); returns it."""
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        for name in self.TABLES:
            schema = self._schema(name)
            if schema is None:
                write_csv(self.table(name), d / f"{name}.csv")
            else:
                schema.to_csv(self.table(name), d / f"{name}.csv")
        (d / self.META_FILE).write_text(json.dumps(self.saved_meta(), indent=1, sort_keys=True, default=str))
        return d

    @classmethod
    def load(cls, directory: str | Path):
        """Read what :meth:`save` wrote."""
        d = Path(directory)
        try:
            tables = {n: pd.read_csv(d / f"{n}.csv", keep_default_na=False, na_values=[""])
                      if cls._schema(n) is None else cls._schema(n).read_csv(d / f"{n}.csv") for n in cls.TABLES}
            meta = json.loads((d / cls.META_FILE).read_text())
        except (OSError, ValueError) as exc:
            raise ResultsError(f"{d}: not a saved {cls.WHAT} ({exc})") from exc
        return cls.from_saved(tables, meta)

    @classmethod
    def from_saved(cls, tables: Mapping[str, pd.DataFrame], meta: Mapping):
        """The bundle of saved ``tables`` (name -> frame) and ``meta``: the ``META_FIELDS`` read back
        with their types, or ``meta`` whole as the field ``meta``."""
        if not cls.META_FIELDS:
            return cls(**tables, meta=dict(meta))
        try:
            scalars = {name: kind(meta[name]) for name, kind in cls.META_FIELDS.items()}
        except (KeyError, TypeError, ValueError) as exc:
            raise ResultsError(f"{cls.META_FILE}: not the metadata of a saved {cls.WHAT} ({exc})") from exc
        return cls(**tables, **scalars)
