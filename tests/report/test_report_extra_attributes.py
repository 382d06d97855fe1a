"""report.json's further keys (``Report.extra``) are attributes, as README's "From Python"
promises of every key: ``report.consistency`` and ``report.parameters`` were an
``AttributeError`` (only ``report.extra["consistency"]`` reached them)."""

import copy
import dataclasses
import json
import pickle

import pytest

from hybridlog.errors import ReportError
from hybridlog.report import build_report, read_report
from tests.report.test_report_files import DT, make_run


def _report(**extra: object):  # type: ignore[no-untyped-def]
    result, signals = make_run(n=30, seed=1)
    return build_report(result, signals, log="run.csv", model_name="tanks", dt=DT, extra=extra)


def test_every_key_of_report_json_is_an_attribute() -> None:
    report = _report(parameters={"A": 150.0}, consistency={"nis": 3.0})
    assert all(hasattr(report, key) for key in report.to_dict())  # typed parts for the others
    assert report.parameters == {"A": 150.0}
    assert report.consistency == {"nis": 3.0}
    assert {"parameters", "consistency", "vaf"} <= set(dir(report))


def test_a_missing_key_is_an_attribute_error_and_copies_still_work() -> None:
    report = _report(parameters={"A": 150.0})
    with pytest.raises(AttributeError, match="'Report' object has no attribute 'consistency'"):
        report.consistency  # noqa: B018
    assert not hasattr(report, "__wrapped__")  # a dunder is never read from extra
    for again in (pickle.loads(pickle.dumps(report)), copy.deepcopy(report)):
        assert again == report
        assert again.parameters == {"A": 150.0}


@pytest.mark.parametrize("key", ["to_dict", "with_extra", "extra", "keeps", "__deepcopy__"])
def test_a_key_named_like_the_reports_own_is_refused_not_hidden(key: str, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``report.to_dict`` of a report whose further key ``to_dict`` was the method: the key
    was kept, unreachable as the attribute README promises (``extra`` gave the mapping)."""
    if key == "keeps":  # a name that is no method: reached as any other key
        assert _report(keeps=1).keeps == 1
        return
    with pytest.raises(ReportError, match=f"run.csv: '{key}' would be hidden: report.<key> reads"):
        _report(**{key: 1})
    with pytest.raises(ValueError, match=f"extra key '{key}' would be hidden"):
        dataclasses.replace(_report(), extra={key: 1})
    data = _report().to_dict()
    data[key] = {"a": 1}
    path = tmp_path / "report.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(
        ReportError, match=rf"report.json: '{key}' would be hidden: .*not a key hybridlog writes"
    ):
        read_report(path)
