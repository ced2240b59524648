"""The contract every stage's result keeps (ARCHITECTURE.md, "What flows between stages"): the text the command line
prints, the JSON it writes, a figure, an HTML report, and a table where the result holds one. Checked against every
result class by tests/test_results.py."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol, runtime_checkable


@runtime_checkable
class Result(Protocol):
    """A stage's result: `summary()` text, `to_dict()` JSON-safe data, `plot(ax=None)` a figure, `report(directory)`
    writes directory/index.html and returns its path (further parameters, where a result has them, have defaults)."""

    def summary(self) -> str: ...

    def to_dict(self) -> dict[str, Any]: ...

    def plot(self, ax: Any = None) -> Any: ...

    def report(self, directory: str | Path) -> Path: ...


@runtime_checkable
class TableResult(Result, Protocol):
    """A result that holds a table: `to_pandas()` gives it as a DataFrame (pandas is an optional dependency)."""

    def to_pandas(self) -> Any: ...
