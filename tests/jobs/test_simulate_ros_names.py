"""Topics ``simulate`` writes are ROS names, and logs of older versions still read.

``simulate`` of ``bioplex_pgc`` wrote ``/truth/mode.fr1`` and a state ``θ`` became
``/truth/θ``: rosbags and mcap read them, ``ros2 bag play`` and rclcpp refuse them.  They are
``/truth/mode/fr1`` and ``/truth/theta`` now; the default mapping looks for the old names as
well, and names that would share a topic are refused before anything is simulated.

The rule checked here is rmw's ``rmw_validate_full_topic_name`` (ROS 2; ROS 1 takes the
same), written out independently of hybridlog's.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

from hybridlog.cli import main
from hybridlog.io import ReadOptions, SignalSpec, bag_writers, load_signals
from hybridlog.jobs.simulate import log_columns, simulate_log
from hybridlog.model.cache import load_model
from hybridlog.simulate import simulate
from hybridlog.simulate_components import simulate_components
from tests.support.cli import run_main as _run
from tests.support.models import PENDULUM_ONE_MODE

# rmw_validate_full_topic_name: absolute, alphanumerics, '_' and '/', no '//', no trailing '/',
# no token starting with a digit, at most 247 characters
ROS_NAME = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+")
MAX_LENGTH = 255 - 8

# (--out name, extra simulate arguments)
MESSAGE_FORMATS = {
    "mcap": ("run.mcap", []),
    "mcap-json": ("run.mcap", ["--encoding", "json"]),
    "ros1-bag": ("run.bag", []),
    "ros2-sqlite3": ("run", ["--format", "ros2-sqlite3"]),
    "ros2-mcap": ("run", ["--format", "ros2-mcap"]),
}


def _topics(log: Path) -> set[str]:
    if log.suffix == ".mcap":
        with log.open("rb") as handle:
            summary = make_reader(handle).get_summary()
        assert summary is not None
        return {channel.topic for channel in summary.channels.values()}
    with AnyReader([log]) as reader:
        return {connection.topic for connection in reader.connections}


def _pendulum(tmp_path: Path, **renames: str) -> Path:
    text = PENDULUM_ONE_MODE
    for old, new in renames.items():
        text = text.replace(old, new)
    path = tmp_path / "pendulum.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _valid(topic: str) -> bool:
    return ROS_NAME.fullmatch(topic) is not None and len(topic) <= MAX_LENGTH


@pytest.mark.parametrize("name", list(MESSAGE_FORMATS))
def test_components_model_topics_are_ros_names(name: str, tmp_path: Path) -> None:
    out, extra = MESSAGE_FORMATS[name]
    log = tmp_path / out
    code = _cli(["simulate", "bioplex_pgc", "--out", str(log), "--steps", "30", *extra])
    assert code == 0
    topics = _topics(log)
    assert all(_valid(topic) for topic in topics), sorted(topics)
    model = load_model("bioplex_pgc")
    assert {f"/truth/mode/{c.name}" for c in model.components} <= topics
    # the default mapping finds every component's true mode, as from the CSV
    signals = load_signals(log, SignalSpec.of(model), ReadOptions())
    table = tmp_path / "run.csv"
    assert _cli(["simulate", "bioplex_pgc", "--out", str(table), "--steps", "30"]) == 0
    expected = load_signals(table, SignalSpec.of(model), ReadOptions())
    assert set(signals.truth_components) == {c.name for c in model.components}
    for component, truth in expected.truth_components.items():
        got = signals.truth_components[component]
        assert [got.labels[c] for c in got.codes] == [truth.labels[c] for c in truth.codes]


def _cli(args: list[str]) -> int:
    try:
        main(args)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    return 0


@pytest.mark.parametrize("name", ["mcap", "ros2-sqlite3"])
def test_unicode_state_is_written_as_a_ros_name(name: str, tmp_path: Path) -> None:
    model_file = _pendulum(tmp_path, theta="θ", omega="ω")
    out, extra = MESSAGE_FORMATS[name]
    log = tmp_path / out
    assert _cli(["simulate", str(model_file), "--out", str(log), "--steps", "20", *extra]) == 0
    topics = _topics(log)
    assert {"/truth/theta", "/truth/omega", "/torque", "/y_sin"} <= topics
    assert all(_valid(topic) for topic in topics), sorted(topics)
    model = load_model(model_file)
    signals = load_signals(log, SignalSpec.of(model), ReadOptions())
    run = simulate(model, steps=20, seed=0)
    assert signals.truth_states is not None
    np.testing.assert_array_equal(signals.truth_states, run.states)


@pytest.mark.parametrize(
    ("renames", "pair", "topic"),
    [
        ({"omega": "θ"}, "'theta' and 'θ'", "/truth/theta"),  # states theta and θ
        ({"omega": "theta_"}, "", ""),  # no clash: both fine
        ({"y_speed": "y_sín"}, "'y_sin' and 'y_sín'", "/y_sin"),  # outputs y_sin and y_sín
    ],
)
def test_names_sharing_a_topic_are_refused_before_simulating(
    renames: dict[str, str],
    pair: str,
    topic: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    model_file = _pendulum(tmp_path, **renames)
    simulated: list[object] = []
    real = simulate

    def counted(*args: object, **kwargs: object) -> object:
        simulated.append(args)
        return real(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr("hybridlog.jobs.simulate.simulate_model", counted)
    log = tmp_path / "run.mcap"
    code, output = _run(["simulate", str(model_file), "--out", str(log), "--steps", "5"], capsys)
    if not pair:
        assert code == 0, output
        assert all(_valid(t) for t in _topics(log))
        return
    assert code == 2, output
    assert output.count("\n") == 1
    assert f"{log}: columns {pair} would both be topic '{topic}'" in output
    assert not log.exists() and not simulated
    # a CSV log has columns, not topics: the same model writes one
    assert _cli(["simulate", str(model_file), "--out", str(tmp_path / "run.csv")]) == 0


def test_a_name_with_nothing_ascii_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model_file = _pendulum(tmp_path, omega="温度")
    log = tmp_path / "run.bag"
    code, output = _run(["simulate", str(model_file), "--out", str(log), "--steps", "5"], capsys)
    assert code == 2, output
    assert output.count("\n") == 1
    assert "column '温度' has no ROS topic name" in output
    assert not log.exists()


def _old_topic_names(path: object, names: list[str], truth: tuple[str, ...] = ()) -> dict[str, str]:
    """The topics of hybridlog before ROS names: ``/truth/<column>``, ``/<column>``."""
    return {name: f"/truth/{name}" if name in truth else f"/{name}" for name in names}


@pytest.mark.parametrize("model_ref", ["bioplex_pgc", "unicode pendulum"])
def test_logs_of_older_versions_still_read(
    model_ref: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    ref = str(_pendulum(tmp_path, theta="θ")) if model_ref != "bioplex_pgc" else model_ref
    old = tmp_path / "old.mcap"
    with monkeypatch.context() as patch:
        patch.setattr(bag_writers, "check_topic_names", _old_topic_names)
        simulate_log(ref, old, steps=25)
    topics = _topics(old)
    assert "/truth/mode.fr1" in topics or "/truth/θ" in topics
    model = load_model(ref)
    signals = load_signals(old, SignalSpec.of(model), ReadOptions())
    new = tmp_path / "new.mcap"
    simulate_log(ref, new, steps=25)
    expected = load_signals(new, SignalSpec.of(model), ReadOptions())
    assert signals.truth_states is not None and expected.truth_states is not None
    np.testing.assert_array_equal(signals.truth_states, expected.truth_states)
    assert set(signals.truth_components) == set(expected.truth_components)
    for name, truth in expected.truth_components.items():
        np.testing.assert_array_equal(signals.truth_components[name].codes, truth.codes)
    if not model.has_components:
        np.testing.assert_array_equal(signals.truth_modes, expected.truth_modes)


@pytest.mark.parametrize("model_ref", ["bioplex_pgc", "three_tank_hstf"])
def test_log_columns_are_the_columns_written(model_ref: str) -> None:
    """The names checked before the run are those the run writes."""
    model = load_model(model_ref)
    if model.has_components:
        played = simulate_components(model, steps=3)
        columns, truth = played.columns(model), played.truth_columns(model)
    else:
        run = simulate(model, steps=3)
        columns, truth = run.columns(model), ("mode", *model.states)
    assert log_columns(model) == (tuple(c for c in columns if c != "t"), truth)
