"""A run whose arrays cannot fit in memory is refused after reading, before they are allocated."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

import hybridlog.memory
from hybridlog.errors import LogError
from hybridlog.estimators import CHUNK_ROWS, prepare
from hybridlog.estimators.footprint import REPORT_FACTOR, result_bytes
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.compare import compare
from hybridlog.memory import check_fits
from hybridlog.model.cache import load_model

Main = Callable[[list[str]], tuple[int, str]]


def _available(monkeypatch: pytest.MonkeyPatch, size: int) -> None:
    monkeypatch.setattr(hybridlog.memory, "available_memory", lambda: size)


def test_the_needs_count_the_result_and_each_offline_pass() -> None:
    model = load_model("three_tank_hstf")  # 3 modes, 3 states, 3 outputs
    n = CHUNK_ROWS  # one chunk: the result comes whole
    plain = prepare(model, "imm", {}).memory_needed(model, n)
    assert plain == [("the estimates", int(8 * n * 13 * REPORT_FACTOR))]
    assert result_bytes(model, n) == 8 * n * 13
    assert prepare(model, "hstf", {}).memory_needed(model, n) == plain
    n = 1_000_000
    smooth = dict(prepare(model, "imm", {"smooth": "true"}).memory_needed(model, n))
    assert smooth["the estimates"] == int(8 * n * 13 * REPORT_FACTOR)
    assert smooth["the smoother's per-mode store"] == 8 * n * 3 * 9  # docs: 206 MiB
    assert smooth["the outputs each side explains"] == 2 * 8 * n * 3
    kbest = dict(
        prepare(model, "imm", {"mode_sequence": "kbest", "beam": "50"}).memory_needed(model, n)
    )
    assert kbest["the k-best histories"] == 6 * n * 50


def test_a_streamed_run_needs_one_chunk_and_the_mode_sequence() -> None:
    """A filter without an offline pass gives its result a chunk at a time: the report keeps
    the estimated modes, nothing else grows with the log."""
    model = load_model("three_tank_hstf")
    n = 1_000_000
    for name in ("imm", "hstf"):
        prepared = prepare(model, name, {})
        assert prepared.streamed(model, n) and not prepared.streamed(model, CHUNK_ROWS)
        assert prepared.memory_needed(model, n) == [
            ("one chunk of the estimates", int(8 * CHUNK_ROWS * 13 * REPORT_FACTOR)),
            ("the estimated modes", 8 * n),
        ]
    assert not prepare(model, "imm", {"mode_sequence": "viterbi"}).streamed(model, n)


def test_check_fits_names_the_largest_parts_and_passes_what_fits() -> None:
    parts = [("a", 3_000_000_000), ("b", 2_000_000_000), ("c", 10), ("d", 1)]
    check_fits(parts, what="x", remedy="r", error=LogError, available=5_000_000_011)
    with pytest.raises(LogError) as raised:
        check_fits(parts, what="x", remedy="r", error=LogError, available=1_000_000_000)
    assert str(raised.value) == (
        "x would need about 5.0 GB of memory (a 3.0 GB, b 2.0 GB, c 0.0 MB) and 1.0 GB is "
        "available; r"
    )


def test_analyze_refuses_before_writing_and_says_what_to_change(
    tmp_path: Path, sample_copy: Callable[[str], Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    log = sample_copy("three_tank_hstf.csv")
    _available(monkeypatch, 100_000)
    out = tmp_path / "out"
    with pytest.raises(LogError) as raised:
        analyze(log, "three_tank_hstf", out_dir=out, estimator="imm", smooth=True)
    message = str(raised.value)
    assert message.startswith(f"{log}: 301 samples through imm would need about ")
    assert "the smoother's per-mode store" in message and "0.1 MB is available" in message
    assert message.endswith("analyse a shorter log, or without --smooth and --mode-sequence")
    assert not out.exists() and list(tmp_path.iterdir()) == [log]
    _available(monkeypatch, 10**12)
    analyze(log, "three_tank_hstf", out_dir=out, estimator="imm", smooth=True)
    assert (out / "report.json").is_file()
    # the k-best histories grow with the beam: a smaller one is named too
    _available(monkeypatch, 1_000_000)
    kbest = tmp_path / "kbest"
    with pytest.raises(LogError, match=r"the k-best histories 18\.1 MB") as raised:
        analyze(
            log, "three_tank_hstf", out_dir=kbest, estimator="imm", mode_sequence="kbest",
            sets=["beam=10000"],
        )  # fmt: skip
    assert str(raised.value).endswith(
        "analyse a shorter log, or without --smooth and --mode-sequence, "
        "or a smaller beam (--set beam=N, now 10000)"
    )
    assert not kbest.exists()


def test_compare_needs_its_largest_estimator_and_batch_fails_only_that_log(
    tmp_path: Path, sample_copy: Callable[[str], Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``compare`` runs its estimators one after the other: the largest need counts."""
    log = sample_copy("three_tank_hstf.csv")
    _available(monkeypatch, 10_000)
    with pytest.raises(LogError, match=r"through imm, hstf would need about "):
        compare(log, "three_tank_hstf", ["imm", "hstf"], out_dir=tmp_path / "cmp")
    model = load_model("three_tank_hstf")
    one = int(result_bytes(model, 301) * REPORT_FACTOR)
    _available(monkeypatch, one + one // 2)  # one estimator's estimates, not both
    compare(log, "three_tank_hstf", ["imm", "hstf"], out_dir=tmp_path / "cmp")
    _available(monkeypatch, 10_000)
    outcome = run_batch([log], "three_tank_hstf", out_dir=tmp_path / "batch", jobs=1)
    (row,) = outcome.logs
    assert row.status == "failed" and "samples through hstf would need about" in (row.error or "")


def test_the_command_line_gives_one_line_and_exit_code_2(
    tmp_path: Path,
    sample_copy: Callable[[str], Path],
    monkeypatch: pytest.MonkeyPatch,
    hybridlog_main: Main,
) -> None:
    log = sample_copy("three_tank_hstf.csv")
    _available(monkeypatch, 10_000)
    code, err = hybridlog_main(
        ["analyze", str(log), "--model", "three_tank_hstf", "--out", str(tmp_path / "o")]
    )
    assert code == 2
    assert err.count("\n") == 1 and "samples through hstf would need about" in err


def test_an_allocation_failing_past_the_check_is_one_line_too(
    tmp_path: Path,
    sample_copy: Callable[[str], Path],
    monkeypatch: pytest.MonkeyPatch,
    hybridlog_main: Main,
) -> None:
    """Under ``ulimit -v`` or a container's limit the machine's free memory overstates it."""
    import hybridlog.jobs.analysis

    def fail(*_: object) -> None:
        raise MemoryError("Unable to allocate 8.00 GiB for an array")

    monkeypatch.setattr(hybridlog.jobs.analysis, "check_memory", fail)
    log = sample_copy("three_tank_hstf.csv")
    code, err = hybridlog_main(
        ["analyze", str(log), "--model", "three_tank_hstf", "--out", str(tmp_path / "o")]
    )
    assert code == 2 and err.count("\n") == 1
    assert err.startswith("hybridlog: error: out of memory") and "ulimit -v" in err
    assert not (tmp_path / "o").exists()
