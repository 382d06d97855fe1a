"""Mutation fuzzing of the log readers: seeded random damage, read in a worker process.

Every sample log (each format, each bag storage, bag folders through their data file or
their ``metadata.yaml``) and the MCAP conformance inputs are copied and damaged -- bytes
flipped at random, cut off, bytes inserted or deleted, lines of a CSV file repeated -- then
inspected and loaded at library level, as ``analyze`` and ``inspect`` do.  Each case must
either read (and then give finite times, inputs and outputs, as every format promises them)
or raise :class:`~hybridlog.errors.LogError` with one line naming the file.  Another
exception is what a user would see as a traceback; a case that runs past its time limit is a
hang, and a worker that dies is a crash: the cases run in a worker process
(``python -m tests.io.mutation_fuzz``, one JSON line per case on stdin and stdout) that is
replaced when either happens.

Run as a script (``python -m tests.io.mutation_fuzz --cases 2000``) for a longer search
than the committed test's.
"""

from __future__ import annotations

import json
import os
import random
import select
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tests.support.paths import ROOT, SAMPLE_LOGS

CONFORMANCE = ROOT / "tests" / "data" / "mcap-conformance"


@dataclass(frozen=True)
class Subject:
    """A log to damage: ``sample`` (a file or bag folder) and the file in it to damage."""

    sample: Path
    inner: str  # "" for the sample itself
    model: str | None  # the builtin model whose signals are loaded, None: inspect only


SUBJECTS: tuple[Subject, ...] = (
    Subject(SAMPLE_LOGS / "three_tank_hstf.csv", "", "three_tank_hstf"),
    Subject(SAMPLE_LOGS / "double_cart_case1.csv", "", "double_cart_case1"),
    Subject(SAMPLE_LOGS / "ice_clutch.csv", "", "ice_clutch"),
    Subject(SAMPLE_LOGS / "bioplex_pgc.csv", "", "bioplex_pgc"),
    Subject(SAMPLE_LOGS / "three_tank_hstf.parquet", "", "three_tank_hstf"),
    Subject(SAMPLE_LOGS / "three_tank_hstf.mcap", "", "three_tank_hstf"),
    Subject(SAMPLE_LOGS / "three_tank_hstf_json.mcap", "", "three_tank_hstf"),
    Subject(SAMPLE_LOGS / "three_tank_hstf_ros1.mcap", "", "three_tank_hstf"),
    Subject(SAMPLE_LOGS / "three_tank_hstf.bag", "", "three_tank_hstf"),
    Subject(SAMPLE_LOGS / "three_tank_hstf_ros2", "three_tank_hstf_ros2.db3", "three_tank_hstf"),
    Subject(SAMPLE_LOGS / "three_tank_hstf_ros2", "metadata.yaml", "three_tank_hstf"),
    Subject(
        SAMPLE_LOGS / "three_tank_hstf_ros2mcap",
        "three_tank_hstf_ros2mcap.mcap",
        "three_tank_hstf",
    ),
    Subject(SAMPLE_LOGS / "three_tank_hstf_ros2mcap", "metadata.yaml", "three_tank_hstf"),
)


def conformance_subjects() -> tuple[Subject, ...]:
    """The MCAP conformance inputs (inspected: their topics are no model's signals)."""
    return tuple(Subject(p, "", None) for p in sorted(CONFORMANCE.glob("*/*.mcap")))


# ---------------------------------------------------------------------- damage

TEXT_PIECES = (b",", b"\n", b"\r", b'"', b"-", b"e", b"e999", b"1e400", b"nan", b" ", b"\x00")


def mutate(data: bytes, rng: random.Random, text: bool) -> tuple[bytes, str]:
    """``data`` damaged by one to three random operations, and what they were."""
    done: list[str] = []
    for _ in range(rng.choice((1, 1, 2, 3))):
        size = len(data)
        at = rng.randrange(size + 1) if size else 0
        how = rng.choice(("flip", "flip", "cut", "insert", "delete", "repeat", "byte"))
        if how == "flip" and size:
            out = bytearray(data)
            count = rng.choice((1, 2, 4, 16))
            for _ in range(count):
                out[rng.randrange(size)] ^= 1 << rng.randrange(8)
            data = bytes(out)
            done.append(f"flip {count} bits")
        elif how == "cut":
            data = data[:at]
            done.append(f"cut at {at}")
        elif how == "insert":
            piece = (
                rng.choice(TEXT_PIECES)
                if text and rng.random() < 0.7
                else rng.randbytes(rng.randrange(1, 17))
            )
            data = data[:at] + piece + data[at:]
            done.append(f"insert {piece!r} at {at}")
        elif how == "delete":
            width = rng.randrange(1, 65)
            data = data[:at] + data[at + width :]
            done.append(f"delete {width} B at {at}")
        elif how == "repeat":
            width = rng.randrange(1, 257)
            data = data[:at] + data[at : at + width] + data[at:]
            done.append(f"repeat {width} B at {at}")
        elif size:
            index = min(at, size - 1)
            value = rng.choice((0x00, 0xFF, 0x7F, 0x80, rng.randrange(256)))
            data = data[:index] + bytes([value]) + data[index + 1 :]
            done.append(f"byte {value:#04x} at {index}")
    return data, "; ".join(done)


def damaged_copy(subject: Subject, folder: Path, seed: int) -> tuple[Path, Path, str]:
    """A damaged copy of ``subject`` in ``folder``: the log, the file damaged, the damage."""
    folder.mkdir(parents=True, exist_ok=True)
    log = folder / subject.sample.name
    if subject.sample.is_dir():
        shutil.copytree(subject.sample, log)
    else:
        shutil.copyfile(subject.sample, log)
    target = log / subject.inner if subject.inner else log
    text = target.suffix in (".csv", ".yaml")
    data, how = mutate(target.read_bytes(), random.Random(seed), text)
    target.write_bytes(data)
    return log, target, how


# ---------------------------------------------------------------------- one case


def read_case(log: str, target: str, model: str | None) -> str | None:
    """Inspect and load ``log``; what went wrong, or ``None``."""
    import numpy as np

    from hybridlog.errors import LogError
    from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
    from hybridlog.model.loader import load_model

    path = Path(log)
    calls: list[tuple[str, Any]] = [("inspect", lambda: inspect_log(path))]
    if model is not None:
        spec = SignalSpec.of(load_model(model))
        recover = [False, True] if path.suffix == ".mcap" else [False]  # read by bare MCAP only
        options = [ReadOptions(recover=flag) for flag in recover]
        # and what the other options read differently: out-of-order and repeated times,
        # non-finite samples, header stamps
        header = "header" if path.suffix in (".mcap", ".bag") or path.is_dir() else "log"
        options.append(ReadOptions(sort=True, drop_nonfinite=True, time=header))
        for option in options:
            calls.append((f"load({option})", lambda o=option: load_signals(path, spec, o)))
    for name, call in calls:
        try:
            result = call()
        except LogError as err:
            message = str(err)
            if "\n" in message:
                return f"{name}: a message of several lines: {message[:300]!r}"
            if log not in message and target not in message:
                return f"{name}: the message does not name the file: {message[:300]!r}"
            continue
        except Exception as err:  # what a user would see as a traceback
            return f"{name}: {type(err).__name__}: {str(err)[:300]}"
        if name.startswith("load"):
            for what in ("time", "inputs", "outputs"):
                values = getattr(result, what)
                if not np.isfinite(values).all():
                    return f"{name}: read, but {what} holds NaN or infinite values"
    return None


def _worker() -> None:
    """Read one JSON case per line from stdin, answer one JSON line per case."""
    import warnings

    warnings.simplefilter("ignore")  # a library's warning is no failure of the reader
    for line in sys.stdin:
        case = json.loads(line)
        if case.get("selftest") == "crash":  # the harness's own test
            os._exit(3)
        if case.get("selftest") == "hang":
            time.sleep(3600)
        problem = read_case(case["log"], case["target"], case["model"])
        sys.stdout.write(json.dumps({"problem": problem}) + "\n")
        sys.stdout.flush()


class Worker:
    """A ``python -m tests.io.mutation_fuzz --worker`` process, restarted after a failure."""

    def __init__(self) -> None:
        self._process: subprocess.Popen[str] | None = None

    def _start(self) -> subprocess.Popen[str]:
        if self._process is None or self._process.poll() is not None:
            env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path])}
            self._process = subprocess.Popen(
                [sys.executable, "-m", "tests.io.mutation_fuzz", "--worker"],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
                text=True,
                cwd=ROOT,
                env=env,
            )
        return self._process

    def run(
        self, log: Path, target: Path, model: str | None, timeout: float, selftest: str = ""
    ) -> str | None:
        """The problem the case shows, ``"hang"`` or ``"crash"``, or ``None``."""
        process = self._start()
        assert process.stdin is not None and process.stdout is not None
        case = {"log": str(log), "target": str(target), "model": model, "selftest": selftest}
        process.stdin.write(json.dumps(case) + "\n")
        process.stdin.flush()
        ready, _, _ = select.select([process.stdout], [], [], timeout)
        if not ready:
            self.close()
            return f"hang: no answer within {timeout:g} s"
        line = process.stdout.readline()
        if not line:
            code = process.wait()
            self.close()
            return f"crash: the worker died (exit code {code})"
        problem: str | None = json.loads(line)["problem"]
        return problem

    def close(self) -> None:
        if self._process is not None:
            self._process.kill()
            self._process.wait()
            for pipe in (self._process.stdin, self._process.stdout):
                if pipe is not None:
                    pipe.close()
            self._process = None


def run_cases(
    subjects: tuple[Subject, ...],
    cases: int,
    folder: Path,
    *,
    seed: int = 0,
    timeout: float = 20.0,
    first_timeout: float = 60.0,
) -> list[str]:
    """Damage ``cases`` copies (round robin over ``subjects``), read each; the failures."""
    failures: list[str] = []
    worker = Worker()
    try:
        for number in range(cases):
            subject = subjects[number % len(subjects)]
            case_seed = seed * 1_000_003 + number
            log, target, how = damaged_copy(subject, folder / str(number), case_seed)
            limit = first_timeout if number == 0 else timeout
            problem = worker.run(log, target, subject.model, limit)
            if problem is not None:
                failures.append(
                    f"{target.relative_to(folder)} (seed {case_seed}: {how}): {problem}"
                )
            shutil.rmtree(folder / str(number))
    finally:
        worker.close()
    return failures


def main(argv: list[str]) -> int:
    import argparse
    import tempfile

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--worker", action="store_true")
    parser.add_argument("--cases", type=int, default=500)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--conformance", action="store_true")
    args = parser.parse_args(argv)
    if args.worker:
        _worker()
        return 0
    subjects = conformance_subjects() if args.conformance else SUBJECTS
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        failures = run_cases(subjects, args.cases, Path(folder), seed=args.seed)
    for failure in failures:
        print(failure)
    print(f"{args.cases} cases, {len(failures)} failures, {time.perf_counter() - start:.1f} s")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
