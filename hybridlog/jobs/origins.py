"""Where each value a run used came from: ``report.json``'s ``parameters`` and ``origins``.

A run's report named the model and the estimator's options, but not the model's parameter
values: two runs of one log with ``--set A=150`` and ``--set A=154`` wrote reports that said
the same model ran, and nothing said which option a ``--set`` had given and which the model
file.  :func:`run_values` gives both keys, added to every report ``analyze``, ``compare`` and
``batch`` write:

- ``parameters``: every ``[parameters]`` value of the model as the run used it;
- ``origins``: for each of them (``parameters.<name>``) and each estimator option
  (``options.<name>``) where its value came from: the command line as typed (``--set
  A=150``), the model file's key (``m.toml: parameters.A``, ``m.toml: estimators.imm.beam``)
  or ``default`` (an option the estimator's defaults gave).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from hybridlog.errors import excerpt
from hybridlog.estimators.options import options_dict
from hybridlog.report.document import DEFAULT_ORIGIN, ORIGINS_KEY, PARAMETERS_KEY

if TYPE_CHECKING:
    from collections.abc import Mapping

    from hybridlog.estimators import Prepared
    from hybridlog.model.hybrid_model import HybridModel


def run_values(
    model: HybridModel, prepared: Prepared, parameter_texts: Mapping[str, str]
) -> dict[str, Any]:
    """``{"parameters": {...}, "origins": {...}}`` of a run (module docstring).

    ``parameter_texts``: the ``--set`` parameters as typed
    (:attr:`hybridlog.jobs.analysis.Overrides.parameter_texts`).
    """
    where = model.origin or model.name
    origins: dict[str, str] = {}
    for name in model.parameters:
        text = parameter_texts.get(name)
        origins[f"parameters.{name}"] = (
            f"{where}: parameters.{name}" if text is None else f"--set {name}={excerpt(text)[1:-1]}"
        )
    for name in options_dict(prepared.options):
        origins[f"options.{name}"] = prepared.origins.get(name, DEFAULT_ORIGIN)
    return {PARAMETERS_KEY: dict(model.parameters), ORIGINS_KEY: origins}
