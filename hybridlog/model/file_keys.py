"""The keys of a model file (SPEC §6), table by table, and the refusals they make.

Which keys each table of fixed keys takes (``[noise]``, ``[initial]``, ``[modes.<id>]`` ...);
which kind of model a file is, listed modes, booleans or components (:func:`model_kind`
refuses the keys of the other kinds); and a top-level key written below a table header,
which TOML puts in that table (:func:`refuse_misplaced_top_keys`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from hybridlog.errors import ModelError
from hybridlog.model.scenario import COMPONENT_KEYS
from hybridlog.model.values import key_path

TOP_KEYS = {
    "name",
    "description",
    "reference",
    "time",
    "dt",
    "integration",
    "states",
    "inputs",
    "outputs",
    "parameters",
    "modes",
    "booleans",
    "dynamics",
    "components",
    "variables",
    "commands",
    "noise",
    "initial",
    "transitions",
    "jumps",
    "signals",
    "truth",
    "default_estimator",
    "estimators",
    "simulation",
}
MODE_KEYS = {"f", "dx", "h", "A", "B", "C", "D", "process_noise", "measurement_noise", "guard"}
DYNAMICS_KEYS = {"f", "dx", "h", "process_noise", "measurement_noise"}
INTEGRATION_KEYS = {"method", "step"}
NOISE_KEYS = {"process", "measurement"}
INITIAL_KEYS = {"state", "covariance", "mode", "mode_probabilities"}
TRANSITION_KEYS = {"matrix", "stay"}
SIMULATION_KEYS = {"state", "state_min", "inputs", "schedule", *COMPONENT_KEYS}


def model_kind(data: Mapping[str, Any]) -> str:
    """``"modes"``, ``"booleans"`` or ``"components"``; refuses keys of the other kinds."""
    if "components" in data:
        for key in ("modes", "booleans", "dynamics", "transitions", "jumps"):
            if key in data:
                raise ModelError(
                    f"{key}: not part of a components model (its modes, equations and "
                    "transition probabilities are in components.<name>)"
                )
        return "components"
    for key in ("variables", "commands"):
        if key in data:
            raise ModelError(f"{key}: only a components model ([components.<name>]) has {key}")
    return "booleans" if "booleans" in data else "modes"


def refuse_misplaced_top_keys(data: Mapping[str, Any]) -> None:
    """Refuse a top-level key written below a table header, before it is missed at the top.

    In TOML every key after ``[initial]`` belongs to ``[initial]``: ``dt = 0.01`` appended
    at the end of a file, or ``time = "continuous"`` below ``[noise]``, was reported as
    ``dt: required key is missing`` (or, for ``time``, as a discrete-time model's ``dx``),
    although the file held it.  Checked in the tables whose keys are fixed (a parameter or
    a state may be called ``dt``) and in each ``[estimators.<name>]`` table, none of whose
    options is named like a top-level key (``default_estimator`` appended below the last
    table of a file that ends with one was "imm has no option 'default_estimator'");
    ``[signals]`` and ``[truth]``, whose keys are symbols, in
    :func:`~hybridlog.model.log_fields._refuse_misplaced`.  A sub-table (``[modes.a.noise]``)
    is no such slip: it is left to the table's own check of its keys.
    """
    tables: list[tuple[str, Any, set[str]]] = [
        (name, data.get(name), allowed)
        for name, allowed in (
            ("noise", NOISE_KEYS),
            ("initial", INITIAL_KEYS),
            ("transitions", TRANSITION_KEYS),
            ("dynamics", DYNAMICS_KEYS),
            ("simulation", SIMULATION_KEYS),
        )
    ]
    modes = data.get("modes")
    if isinstance(modes, dict):
        tables += [(key_path("modes", i), spec, MODE_KEYS) for i, spec in modes.items()]
    estimators = data.get("estimators")
    if isinstance(estimators, dict):  # no option is named like a top-level key
        tables += [(key_path("estimators", n), spec, set()) for n, spec in estimators.items()]
    for where, table, allowed in tables:
        if not isinstance(table, dict):
            continue
        for key in table:
            if key in TOP_KEYS and key not in allowed and not isinstance(table[key], dict):
                raise ModelError(misplaced_top_key(where, key))


def misplaced_top_key(where: str, key: str) -> str:
    """The error of the top-level ``key`` written below the header of the table ``where``."""
    return (
        f"{key_path(where, key)}: {key!r} is a top-level key, but written below "
        f"the [{where}] header, it belongs to that table; move it above the "
        "first [table] header"
    )
