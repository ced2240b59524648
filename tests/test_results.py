"""The result contract (sloshid.core.results): every stage's result has summary / to_dict / plot / report (and
to_pandas where it holds a table) with the same calling convention, and is built with keywords only."""

from __future__ import annotations

import dataclasses
import inspect

import pytest

from sloshid.comparison.compare import Comparison
from sloshid.core.results import Result, TableResult
from sloshid.identification.estimator import IdentResult
from sloshid.planning.planner import PlanResult
from sloshid.tracking.inspect import InspectResult
from sloshid.tracking.tracker import TrackResult
from sloshid.validation.iofit import IOFit
from sloshid.validation.validate import Validation

TABLES = [TrackResult, IdentResult, PlanResult, Comparison, IOFit, Validation]
"""Results that hold a table (to_pandas)."""
RESULTS = [*TABLES, InspectResult]


def _extra_parameters_have_defaults(method, first: list[str]) -> bool:
    params = list(inspect.signature(method).parameters.values())[1:]  # after self
    named = [p.name for p in params[: len(first)]]
    return named == first and all(p.default is not p.empty for p in params[len(first) :])


@pytest.mark.parametrize("cls", RESULTS, ids=lambda c: c.__name__)
def test_every_result_keeps_the_contract(cls):
    assert issubclass(cls, Result)
    assert issubclass(cls, TableResult) == (cls in TABLES)
    assert _extra_parameters_have_defaults(cls.summary, [])
    assert _extra_parameters_have_defaults(cls.to_dict, [])
    assert (
        _extra_parameters_have_defaults(cls.plot, ["ax"])
        and inspect.signature(cls.plot).parameters["ax"].default is None
    )
    assert _extra_parameters_have_defaults(cls.report, ["directory"])
    for name in ("summary", "to_dict", "plot", "report"):
        assert (inspect.getdoc(getattr(cls, name)) or "").strip(), f"{cls.__name__}.{name} says what it gives"


@pytest.mark.parametrize("cls", RESULTS, ids=lambda c: c.__name__)
def test_every_result_is_built_with_keywords(cls):
    assert dataclasses.is_dataclass(cls)
    assert all(f.kw_only for f in dataclasses.fields(cls) if f.init), cls.__name__


def test_every_json_file_states_its_schema_version_and_a_newer_major_is_refused(tmp_path):
    import json

    from sloshid.core.atomic import SCHEMA_VERSION, write_json
    from sloshid.core.errors import UserError
    from sloshid.model.pendulum import SloshParams

    doc = {"parameters": {"omega_rad_s": {"value": 20.0}, "zeta": {"value": 0.03}, "m_kg": {"value": 1.0}}}
    path = tmp_path / "p.json"
    write_json(path, doc)
    assert json.loads(path.read_text())["schema_version"] == SCHEMA_VERSION
    assert SloshParams.from_identify_json(path).zeta == 0.03
    (tmp_path / "old.json").write_text(json.dumps(doc))  # written before versions were stated: read as before
    assert SloshParams.from_identify_json(tmp_path / "old.json").zeta == 0.03
    (tmp_path / "minor.json").write_text(json.dumps({**doc, "schema_version": "1.7"}))  # a newer minor only adds keys
    assert SloshParams.from_identify_json(tmp_path / "minor.json").zeta == 0.03
    (tmp_path / "new.json").write_text(json.dumps({**doc, "schema_version": "2.0"}))
    with pytest.raises(
        UserError, match=r"written by a newer sloshid \(schema_version 2.0, this one reads 1.x\)"
    ) as exc:
        SloshParams.from_identify_json(tmp_path / "new.json")
    assert str(exc.value).count(". ") == 0  # one sentence
