"""Where each value a run used came from: ``report.json``'s ``parameters`` and ``origins``.

A run's report named the model and the estimator's options, but not the model's parameter
values: two runs of one log with ``--set A=150`` and ``--set A=154`` wrote reports that said
the same model ran, and nothing said which option a ``--set`` had given and which the model
file.  :func:`run_values` gives both keys, added to every report ``analyze``, ``compare`` and
``batch`` write:

- ``parameters``: every ``[parameters]`` value of the model as the run used it;
- ``origins``: for each of them (``parameters.<name>``) and each estimator option
  (``options.<name>``) where its value came from: the command line as typed (``--set
  A=150``), the model file's key (``m.toml: parameters.A``, ``m.toml: estimators.imm.beam``),
  the key of a file an option names (``c.json: chiu.parameters.radius``: loaded centres'
  clustering options, the options' ``from_files()``) or ``default`` (an option the
  estimator's defaults gave).

The same origins name, in an error a run raises, the command-line values that changed what
failed (:func:`given_values`, :func:`~hybridlog.errors.given_in_errors`):
``switching-observer diverged at t = 0.01 s ... (after --set fE=1000)``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, TypeVar

from hybridlog.errors import given_in_errors, set_text
from hybridlog.estimators.options import options_dict
from hybridlog.report.document import DEFAULT_ORIGIN, ORIGINS_KEY, PARAMETERS_KEY

T = TypeVar("T")

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable, Iterator, Mapping

    from hybridlog.estimators import Prepared
    from hybridlog.model.hybrid_model import HybridModel


def run_values(
    model: HybridModel, prepared: Prepared, parameter_texts: Mapping[str, str]
) -> dict[str, Any]:
    """``{"parameters": {...}, "origins": {...}}`` of a run (module docstring).

    ``parameter_texts``: the ``--set`` parameters as typed
    (:attr:`hybridlog.jobs.overrides.Overrides.parameter_texts`).
    """
    where = model.origin or model.name
    origins: dict[str, str] = {}
    for name in model.parameters:
        text = parameter_texts.get(name)
        origins[f"parameters.{name}"] = (
            f"{where}: parameters.{name}" if text is None else set_text(name, text)
        )
    from_files: Callable[[], Mapping[str, str]] | None = getattr(
        prepared.options, "from_files", None
    )
    filed = {} if from_files is None else from_files()
    for name in options_dict(prepared.options):
        origins[f"options.{name}"] = prepared.origins.get(name) or filed.get(name, DEFAULT_ORIGIN)
    return {PARAMETERS_KEY: dict(model.parameters), ORIGINS_KEY: origins}


def given_values(
    parameter_texts: Mapping[str, str], prepared: Prepared | None = None
) -> dict[str, str]:
    """Name → command-line option of each value a run of the model (and ``prepared``) uses.

    The ``--set`` parameters as typed, then the options of ``prepared`` the command line
    gave (``--set beam=50``, ``--smooth``): what :func:`~hybridlog.errors.given_in_errors`
    names.
    """
    given = {name: set_text(name, text) for name, text in parameter_texts.items()}
    if prepared is not None:
        given.update((k, v) for k, v in prepared.origins.items() if v.startswith("--"))
    return given


def given_in_chunks(run: Callable[[], Iterable[T]], given: Mapping[str, str]) -> Iterator[T]:
    """The chunks ``run()`` gives (an estimator's result), its errors naming ``given``.

    As :func:`~hybridlog.errors.given_in_errors` names them.

    ``run`` is called inside, when the first chunk is asked for: a result computed whole
    raises as it is called (chiu's ``cluster_modes``: 2 mode ids for 42 clusters).
    """
    with given_in_errors(given):
        yield from run()
