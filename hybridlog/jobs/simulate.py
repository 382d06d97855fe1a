"""The ``hybridlog simulate`` job: a simulated run of a model, written as a log.

The simulation itself is the pure algorithm :func:`hybridlog.simulate.simulate`; this job
loads the model, checks the output before simulating (it must not replace, contain or sit
inside the model file; an existing target needs ``force``), and writes the log with ground
truth (:func:`hybridlog.io.bag_writers.write_log`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from hybridlog.io.bag_writers import check_log_target, write_log
from hybridlog.model.cache import load_model
from hybridlog.outputs import PathLike
from hybridlog.simulate import parse_disturbance
from hybridlog.simulate import simulate as simulate_model

__all__ = ["SimulationOutcome", "simulate_log"]


@dataclass(frozen=True)
class SimulationOutcome:
    """What ``hybridlog simulate`` wrote: the log and its number of samples (rows)."""

    path: Path
    samples: int


def simulate_log(
    model_ref: str | Path,
    out: PathLike,
    *,
    log_format: str | None = None,
    encoding: str = "cdr",
    schedule: str | None = None,
    steps: int | None = None,
    seed: int = 0,
    noise: bool = True,
    disturbance: str | None = None,
    force: bool = False,
) -> SimulationOutcome:
    """Simulate ``model_ref`` and write the run to ``out`` with its true modes and states.

    Parameters
    ----------
    model_ref:
        Built-in model name or model file.
    out:
        The log: ``.csv``, ``.parquet``, ``.mcap``, ``.bag``, or a ROS 2 bag folder.
    log_format, encoding:
        As for :func:`hybridlog.io.bag_writers.write_log` (format from the suffix when
        ``None``; the message encoding of an MCAP file).
    schedule, steps, seed, noise:
        As for :func:`hybridlog.simulate.simulate`.
    disturbance:
        ``"A,OMEGA"``: the :class:`~hybridlog.simulate.Disturbance` of paper 003 eq. (49).
    force:
        Replace an existing file, or a ROS 2 bag folder hybridlog wrote (never the model).

    Raises
    ------
    HybridlogError
        A bad model, option or output, each found before anything is simulated or written.
    """
    parsed = parse_disturbance(disturbance) if disturbance is not None else None
    model = load_model(model_ref)
    inputs: list[tuple[str, PathLike]] = (
        [("model file", model_ref)] if Path(model_ref).exists() else []
    )
    # Every check of the output runs before the simulation.
    check_log_target(out, format=log_format, encoding=encoding, force=force, inputs=inputs)
    log = simulate_model(
        model, schedule=schedule, steps=steps, seed=seed, noise=noise, disturbance=parsed
    )
    path = write_log(
        out,
        log.columns(model),
        truth=("mode", *model.states),
        format=log_format,
        encoding=encoding,
        force=force,
        inputs=inputs,
    )
    return SimulationOutcome(path=path, samples=int(log.time.shape[0]))
