"""report.json's further keys (``Report.extra``) are attributes, as README's "From Python"
promises of every key: ``report.consistency`` and ``report.parameters`` were an
``AttributeError`` (only ``report.extra["consistency"]`` reached them)."""

import copy
import pickle

import pytest

from hybridlog.report import build_report
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
