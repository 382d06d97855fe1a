"""A long ``unknown-mode`` run says about how long it will take, as chiu's long work does.

``--set beam=10000`` on a 400-sample log of one component took 59 s with nothing printed.
The tests make every run "long" (``LONG_WORK_S`` below any time, no calibration time)
instead of timing a slow one.
"""

import contextlib

import pytest

from hybridlog.cluster import progress
from hybridlog.cluster.progress import WorkReporter, reporting
from hybridlog.estimators.cpha.unknown_mode import UnknownModeOptions, run_unknown_mode
from hybridlog.model.loader import parse_model
from tests.support.cpha import CPHA_EXAMPLE, cpha_log


def recording_reporter():
    said = {"notes": [], "bars": [], "advanced": 0}

    @contextlib.contextmanager
    def bar(total, label):
        said["bars"].append((total, label))

        def advance(done):
            said["advanced"] += done

        yield advance

    return WorkReporter(note=said["notes"].append, bar=bar), said


def run(reporter):
    model = parse_model(CPHA_EXAMPLE, origin="cpha.toml")
    signals = cpha_log(model, 30, seed=1)
    with reporting(reporter):
        return run_unknown_mode(model, signals, UnknownModeOptions(beam=3))


def test_a_long_run_says_how_long_and_shows_its_steps(monkeypatch):
    monkeypatch.setattr(progress, "CALIBRATION_S", 0.0)
    monkeypatch.setattr(progress, "LONG_WORK_S", -1.0)
    reporter, said = recording_reporter()
    run(reporter)
    [note] = said["notes"]
    assert note.startswith("unknown-mode over 30 samples, beam 3: about ")
    assert "more on this machine" in note and "compilation excluded" in note
    assert said["bars"] == [(29, "unknown-mode steps")]
    assert said["advanced"] == 29  # every step, those timed included


@pytest.mark.parametrize("installed", [True, False])
def test_a_short_run_or_one_without_a_reporter_says_nothing(monkeypatch, installed):
    monkeypatch.setattr(progress, "CALIBRATION_S", 0.0)
    monkeypatch.setattr(progress, "LONG_WORK_S", float("inf") if installed else -1.0)
    reporter, said = recording_reporter()
    result = run(reporter if installed else None)
    assert said == {"notes": [], "bars": [], "advanced": 0}
    assert len(result.modes) == 30
