"""Analyses saved as one CSV per table plus a JSON file of metadata (mutation, study).

A frozen dataclass whose fields are its tables (DataFrames, named in ``TABLES``) and ``meta``
(a dict) inherits :class:`TableBundle`: ``table(name)``, ``save(directory)`` and
``load(directory)``, with the metadata in ``META_FILE``.  A table with a
:class:`~faultlab.analysis.schema.TableSchema` in ``SCHEMAS`` is written and read by its schema
(:meth:`~faultlab.analysis.schema.TableSchema.to_csv`, ``read_csv``), so it loads back exactly.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import ClassVar

import pandas as pd

from faultlab.analysis.schema import TableSchema
from faultlab.errors import ResultsError

__all__ = ["TableBundle"]


class TableBundle:
    """Mixin: tables by name, saved as ``<name>.csv`` and metadata as ``META_FILE``."""

    TABLES: ClassVar[tuple[str, ...]] = ()
    META_FILE: ClassVar[str] = "meta.json"
    WHAT: ClassVar[str] = "analysis"
    SCHEMAS: ClassVar[tuple[TableSchema, ...]] = ()

    @classmethod
    def _schema(cls, name: str) -> TableSchema | None:
        return next((s for s in cls.SCHEMAS if s.name == name), None)

    def table(self, name: str) -> pd.DataFrame:
        if name not in self.TABLES:
            raise ResultsError(f"unknown {self.WHAT} table {name!r}; known: {', '.join(self.TABLES)}")
        return getattr(self, name)

    def save(self, directory: str | Path) -> Path:
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        for name in self.TABLES:
            schema = self._schema(name)
            if schema is None:
                self.table(name).to_csv(d / f"{name}.csv", index=False)
            else:
                schema.to_csv(self.table(name), d / f"{name}.csv")
        (d / self.META_FILE).write_text(json.dumps(self.meta, indent=1, sort_keys=True, default=str))
        return d

    @classmethod
    def load(cls, directory: str | Path):
        d = Path(directory)
        try:
            tables = {n: pd.read_csv(d / f"{n}.csv", keep_default_na=False, na_values=[""])
                      if cls._schema(n) is None else cls._schema(n).read_csv(d / f"{n}.csv") for n in cls.TABLES}
            meta = json.loads((d / cls.META_FILE).read_text())
        except (OSError, ValueError) as exc:
            raise ResultsError(f"{d}: not a saved {cls.WHAT} ({exc})") from exc
        return cls(**tables, meta=meta)
