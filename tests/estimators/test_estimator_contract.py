"""The estimator contract, checked for every registered estimator (issue 8).

Each estimator runs on a small simulated log of a model its capabilities accept (the
nonlinear three-tank for the filters, the linear double cart for the clustering observers):
the result's shapes, probabilities, determinism, option errors and the options written to the
report are the same contract for all of them.
"""

import dataclasses
import json
import subprocess
import sys
import typing
from types import MappingProxyType

import numpy as np
import pytest

from hybridlog.errors import HybridlogError, LogError, ModelError, OptionError
from hybridlog.estimators import ESTIMATORS, Capabilities, Estimator, get_estimator, prepare
from hybridlog.estimators.capabilities import ModelTraits
from hybridlog.estimators.offline_options import admits, not_offered
from hybridlog.estimators.options import option, options_dict
from hybridlog.estimators.result import EstimationResult, ResultShapeError
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.overrides import Overrides, parse_sets, prepare_estimators
from hybridlog.model.loader import load_model, parse_model
from hybridlog.report import build_report
from hybridlog.simulate import simulate
from tests.support import clutch, model_kinds
from tests.support.cpha import CPHA_EXAMPLE, cpha_log
from tests.support.paths import ROOT
from tests.support.unmeasured import assert_same

TANK_TEXT = (ROOT / "hybridlog/model/builtin/three_tank_hstf.toml").read_text()
SAMPLE = ROOT / "sample_logs" / "three_tank_hstf.csv"
HEAVY = ("numba", "sympy", "scipy", "cvxpy", "matplotlib", "polars")


def model_for(name):
    if name == "switching-observer":
        return "ice_clutch"
    if ESTIMATORS[name].capabilities.needs_components:
        return "cpha_example"
    if ESTIMATORS[name].capabilities.needs_boolean_affine:
        return "three_tank_valves"
    return (
        "double_cart_case1"
        if ESTIMATORS[name].capabilities.needs_linear_model
        else ("three_tank_hstf")
    )


def clutch_case():
    """The engine with clutch (continuous time, jumps): a short log made with SciPy."""
    model = load_model("ice_clutch")
    values = {k: float(v) for k, v in model.parameters.items()}
    modes = clutch.schedule_modes([(0, 40), (1, 40), (0, 40)])
    times, alpha, states = clutch.trajectory(
        values, modes, [0.08, 140.0, 15.0], lambda t: 0.4 + 0.1 * np.sin(2 * t), model.dt
    )
    return model, clutch.signals(times, alpha, states, modes)


def model_text(name):
    """The model file text of a case (a built-in's, or the components example's)."""
    if name == "cpha_example":
        return CPHA_EXAMPLE
    return (ROOT / f"hybridlog/model/builtin/{name}.toml").read_text()


@pytest.fixture(scope="module")
def cases():
    """Model and a short simulated log per model name, built once."""
    built = {}
    for model_name, steps in (
        ("three_tank_hstf", 120),
        ("double_cart_case1", 300),
        ("three_tank_valves", 300),
    ):
        model = load_model(model_name)
        built[model_name] = (model, simulate(model, steps=steps, seed=1).signals(model))
    built["ice_clutch"] = clutch_case()
    components = parse_model(CPHA_EXAMPLE)
    built["cpha_example"] = (components, cpha_log(components, 80, seed=1))
    return built


@pytest.fixture(scope="module")
def runs(cases):
    """Every estimator run twice on its case, through the registry."""
    results = {}
    for name in ESTIMATORS:
        model, signals = cases[model_for(name)]
        prepared = prepare(model, name)
        results[name] = (prepared, prepared.run(model, signals), prepared.run(model, signals))
    return results


def test_the_registry_imports_no_heavy_library():
    code = (
        "import sys, hybridlog.estimators as e; "
        "assert len(e.ESTIMATORS) >= 4 and all(e.ESTIMATORS[n].summary for n in e.ESTIMATORS); "
        f"print(','.join(m for m in {HEAVY!r} if m in sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == ""


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_entry_is_complete(name):
    entry = ESTIMATORS[name]
    assert entry.name == name and entry.summary and entry.source
    assert dataclasses.is_dataclass(entry.options_type)
    assert callable(entry.run_function)
    assert isinstance(entry.capabilities, Capabilities)
    # An estimator offers smoothing exactly when its options have the switch (issue 12).
    fields = {f.name for f in dataclasses.fields(entry.options_type)}
    assert entry.capabilities.supports_smoothing == ("smooth" in fields)
    # ... and says why when it does not: the refusal's reason
    assert bool(entry.capabilities.no_smoothing) != entry.capabilities.supports_smoothing
    # ... and, without mode_sequence, how it decides its modes: --mode-sequence argmax's reason
    assert bool(entry.capabilities.mode_rule) != ("mode_sequence" in fields)


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_result_shapes_and_probabilities(name, cases, runs):
    model, signals = cases[model_for(name)]
    _, result, _ = runs[name]
    n = signals.n_samples
    assert result.estimator == name
    np.testing.assert_array_equal(result.time, signals.time)
    if model.has_components:  # joint assignments, one mode per component (unknown-mode)
        assert all(len(m.split("|")) == len(model.components) for m in result.mode_ids)
    else:
        assert result.mode_ids == model.mode_ids
    assert result.modes.shape == (n,) and result.modes.dtype == np.int64
    assert result.mode_probabilities.shape == (n, len(result.mode_ids))
    assert result.state_means.shape == result.state_variances.shape == (n, model.n_states)
    assert result.output_predictions.shape == (n, model.n_outputs)
    probabilities = result.mode_probabilities
    assert np.all(probabilities >= 0.0)
    np.testing.assert_allclose(probabilities.sum(axis=1), 1.0, atol=1e-9)
    assert np.all(np.isnan(result.output_predictions[0]))
    assert np.all(np.isfinite(result.output_predictions[1:]))
    assert np.all(np.isfinite(result.state_means))


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_two_runs_are_equal(name, runs):
    _, first, second = runs[name]
    for field in ("modes", "mode_probabilities", "state_means", "state_variances"):
        np.testing.assert_array_equal(getattr(first, field), getattr(second, field))
    np.testing.assert_array_equal(first.output_predictions, second.output_predictions)


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_no_estimator_reads_a_value_the_log_did_not_measure(name, cases):
    """A stand-in the alignment put where an output was not measured changes nothing.

    Updating on it counted a sample twice (imm's mode accuracy on a log whose y2 came at
    half the rate: 74 % against 99 %).  Each estimator either runs on the measured outputs
    alone, giving the same result whatever the stand-ins are, or refuses the log (one line)
    whatever they are.
    """
    model, signals = cases[model_for(name)]
    unmeasured = np.random.default_rng(7).random(signals.outputs.shape) < 0.2
    unmeasured[:2] = False
    prepared = prepare(model, name)
    outcomes = []
    for shift in (0.0, 5.0):
        stand_ins = dataclasses.replace(
            signals,
            outputs=np.where(unmeasured, signals.outputs + shift, signals.outputs),
            unmeasured_outputs=unmeasured,
        )
        try:
            result = prepared.run(model, stand_ins)
            # a second run hits the first's caches: its notes' cache counts differ
            notes = tuple(n for n in result.notes if not n.startswith("decompositions:"))
            outcomes.append(dataclasses.replace(result, notes=notes))
        except LogError as refused:
            outcomes.append(str(refused))
    assert_same(outcomes[0], outcomes[1])
    if isinstance(outcomes[0], str):  # refused: only an estimator that needs every sample
        assert ESTIMATORS[name].capabilities.needs_measured_state, outcomes[0]


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_options_round_trip_through_the_report(name, cases, runs):
    model, signals = cases[model_for(name)]
    prepared, result, _ = runs[name]
    report = build_report(result, signals, log="sim", model_name=model.name, dt=model.dt)
    written = json.loads(report.to_json())["options"]
    declared = [info.name for info in prepared.estimator.describe_options()]
    assert set(declared) <= set(written)
    again = prepared.estimator.parse_options({k: written[k] for k in declared})
    assert again == prepared.options
    assert prepared.options_dict() == {k: result.options[k] for k in declared}


def bad_values(estimator):
    """(option, raw value, what the message says) for every option that has a bad value."""
    cls = estimator.options_type
    hints = typing.get_type_hints(cls)
    for field in dataclasses.fields(cls):
        hint = hints[field.name]
        members = [a for a in typing.get_args(hint) if a is not type(None)] or [hint]
        base = members[0] if typing.get_origin(hint) is not typing.Literal else hint
        if base is bool:
            yield field.name, "maybe", "expected true or false"
        elif typing.get_origin(base) is typing.Literal:
            yield field.name, "no-such-choice", "is not one of"
        elif base in (int, float):
            number = "a whole number" if base is int else "a finite number"
            yield field.name, "abc", f"expected {number}"
            if "range" in field.metadata:
                yield field.name, str(2 * field.metadata["range"][1] + 1), "is outside"


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_a_bad_set_option_is_one_line_naming_estimator_and_option(name, cases):
    model, _ = cases[model_for(name)]
    checked = 0
    for key, raw, reason in bad_values(ESTIMATORS[name]):
        overrides = Overrides(options=MappingProxyType({key: raw}))
        with pytest.raises(OptionError) as caught:
            prepare_estimators(model, [name], overrides)
        message = str(caught.value)
        assert message.startswith(f"--set {key}={raw}: {name} option '{key}': ")
        assert reason in message
        assert "\n" not in message
        checked += 1
    assert checked >= 1


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_a_bad_option_in_the_model_file_names_file_and_key(name, tmp_path):
    key, raw, reason = next(bad_values(ESTIMATORS[name]))
    text = model_text(model_for(name))
    text = text.split("\n[estimators.")[0]  # the built-in's own table, if any, is the last
    path = tmp_path / "model.toml"
    path.write_text(f"{text}\n[estimators.{name}]\n{key} = {json.dumps(raw)}\n")
    model = load_model(path)
    with pytest.raises(ModelError) as caught:
        prepare(model, name)
    message = str(caught.value)
    assert message.startswith(f"{path}: estimators.{name}.{key}: {name} option '{key}': ")
    assert reason in message


def test_range_errors_name_the_file_key_or_the_set_value(tmp_path):
    path = tmp_path / "tank.toml"
    path.write_text(TANK_TEXT.replace("theta = 0.95", "theta = 2.0"))
    model = load_model(path)
    with pytest.raises(ModelError, match=rf"^{path}: estimators\.hstf\.theta: hstf option 'theta'"):
        prepare(model, "hstf")
    # the file is validated as a whole: --set theta=0.9 does not hide its bad value
    with pytest.raises(ModelError, match=rf"^{path}: estimators\.hstf\.theta: hstf option 'theta'"):
        prepare(model, "hstf", {"theta": "0.9"})
    good = load_model("three_tank_hstf")
    assert prepare(good, "hstf", {"theta": "0.9"}).options.theta == 0.9  # --set wins
    with pytest.raises(OptionError, match=r"^--set rho=0: hstf option 'rho': 0 is outside"):
        prepare(good, "hstf", {"rho": "0"})


def test_a_bad_default_estimator_names_the_model_file_and_key(tmp_path):
    path = tmp_path / "tank.toml"
    path.write_text(TANK_TEXT.replace('default_estimator = "hstf"', 'default_estimator = "hsft"'))
    with pytest.raises(ModelError) as caught:
        analyze(SAMPLE, path, out_dir=tmp_path / "out")
    message = str(caught.value)
    assert message.startswith(f"{path}: default_estimator: unknown estimator 'hsft'")
    assert "did you mean 'hstf'" in message and "--estimator" not in message
    assert not (tmp_path / "out").exists()
    # naming another estimator does not hide it: the typo is an error of the file, as an
    # unknown option of an [estimators.<x>] table is whichever estimator runs
    with pytest.raises(ModelError, match=r"default_estimator: unknown estimator 'hsft'"):
        prepare(load_model(path), "imm")


def test_unknown_estimator_tables_and_names(tmp_path):
    path = tmp_path / "tank.toml"
    path.write_text(f"{TANK_TEXT}\n[estimators.kalman]\nq = 1\n")
    with pytest.raises(ModelError, match=rf"^{path}: estimators\.kalman: unknown estimator"):
        prepare(load_model(path), "hstf")
    path.write_text(f"{TANK_TEXT}\n[estimators.imm]\ntransition_stay = 0.9\n")  # another's
    assert prepare(load_model(path), "hstf").name == "hstf"
    # every table's option names are checked, not only the chosen estimator's: another's
    # unknown option is an error of the file whichever estimator runs (it was ignored);
    # and so are their values (transition_stay = 7 under imm passed when hstf ran)
    hstf_smooth = TANK_TEXT.replace("[estimators.hstf]", "[estimators.hstf]\nsmooth = true")
    for text, error in (
        (hstf_smooth, r"estimators\.hstf\.smooth: estimator 'hstf' does not offer it: under"),
        (f"{TANK_TEXT}\n[estimators.imm]\nsmoth = true\n", r"estimators\.imm\.smoth: .*'smooth'"),
    ):
        path.write_text(text)
        model = load_model(path)
        for chosen in ("hstf", "imm"):
            with pytest.raises(ModelError, match=rf"^{path}: {error}"):
                prepare(model, chosen)
    path.write_text(f"{TANK_TEXT}\n[estimators.imm]\nbeam = 0\n")
    for chosen, sets in (("hstf", {}), ("imm", {"beam": "5"})):
        with pytest.raises(ModelError, match=rf"^{path}: estimators\.imm\.beam: .* outside"):
            prepare(load_model(path), chosen, sets)
    with pytest.raises(OptionError, match=r"^--estimator: unknown estimator 'im' .*mean 'imm'"):
        get_estimator("im")


@pytest.mark.parametrize(
    ("table", "key", "value"),
    [
        (name, key, value)
        for name, estimator in ESTIMATORS.items()
        for key, value in (("smooth", "true"), ("mode_sequence", '"viterbi"'), ("beam", "5"))
        if not admits(estimator, key)
    ],
)
def test_offline_key_in_a_table_says_why_as_set_does(tmp_path, table, key, value):
    """An offline pass's key under an estimator without one is refused with the reason.

    ``smooth = true`` under ``[estimators.hstf]`` said "hstf has no option 'smooth'", where
    ``--set smooth=true`` says why hstf has no offline pass and which estimators have one.
    """
    path = tmp_path / "tank.toml"
    header = f"[estimators.{table}]\n"
    text = TANK_TEXT if header in TANK_TEXT else f"{TANK_TEXT}\n{header}"
    path.write_text(text.replace(header, f"{header}{key} = {value}\n"))
    with pytest.raises(ModelError) as caught:
        prepare(load_model(path), "imm")
    why = not_offered(ESTIMATORS[table], key, value.strip('"'), ESTIMATORS.values())
    assert str(caught.value) == f"{path}: estimators.{table}.{key}: estimator '{table}' {why}"
    assert "does not offer it: " in why and "(estimators that do: imm" in why


def test_set_bogus_lists_parameters_and_options_and_suggests(tmp_path):
    model, overrides = parse_sets(["thetta=0.9"], "three_tank_hstf")
    with pytest.raises(OptionError) as caught:
        prepare_estimators(model, [None], overrides)
    message = str(caught.value)
    assert message.startswith("--set thetta=0.9: neither a parameter of model three_tank_hstf")
    assert "parameters: A, " in message and "options of hstf: rho, beta, theta" in message
    assert message.endswith("did you mean 'theta'?")
    model, overrides = parse_sets(["Az=3"], "three_tank_hstf")
    with pytest.raises(OptionError, match="did you mean 'A'"):
        prepare_estimators(model, ["imm"], overrides)


def test_set_values_are_split_once_into_an_immutable_value():
    model, overrides = parse_sets(["A=160", "theta=0.9"], "three_tank_hstf")
    assert dict(overrides.parameters) == {"A": 160.0} and model.parameters["A"] == 160.0
    assert dict(overrides.options) == {"theta": "0.9"}
    with pytest.raises(TypeError):
        overrides.options["rho"] = "0.5"
    with pytest.raises(dataclasses.FrozenInstanceError):
        overrides.options = {}
    with pytest.raises(OptionError, match=r"^--set theta: given twice$"):
        parse_sets(["theta=0.9", "theta=0.8"], "three_tank_hstf")
    with pytest.raises(OptionError, match=r"^--set: 'theta' is not NAME=VALUE$"):
        parse_sets(["theta"], "three_tank_hstf")


def test_each_compared_estimator_gets_the_options_it_declares():
    model, overrides = parse_sets(["theta=0.9", "transition_stay=0.8"], "three_tank_hstf")
    hstf, imm = prepare_estimators(model, ["hstf", "imm"], overrides, given_by="--estimators")
    assert hstf.options.theta == 0.9 and imm.options.transition_stay == 0.8


def test_capabilities_refuse_an_unsuitable_model_naming_file_and_estimator(tmp_path):
    path = tmp_path / "tank.toml"
    path.write_text(TANK_TEXT)
    with pytest.raises(ModelError) as caught:
        prepare(load_model(path), "chiu")
    assert str(caught.value) == (
        f"{path}: estimator 'chiu' needs a linear model; the modes are nonlinear: "
        "modes.1.f[0] is not affine in x1, x3 (estimators for this model: hstf, imm)"
    )
    path.write_text(TANK_TEXT.replace('default_estimator = "hstf"', 'default_estimator = "chiu"'))
    with pytest.raises(ModelError, match=rf"^{path}: default_estimator 'chiu' needs a linear"):
        prepare(load_model(path), None)


def test_capabilities_checks_for_every_need(cases):
    tank, tank_signals = cases["three_tank_hstf"]
    cart, _ = cases["double_cart_case1"]
    tank_traits, cart_traits = ModelTraits(tank), ModelTraits(cart)
    assert cart_traits.nonlinear is None and tank_traits.nonlinear is not None
    assert Capabilities().mismatch(tank_traits) is None
    assert "continuous-time model" in Capabilities(continuous_time=True).mismatch(tank_traits)
    assert "[components]" in Capabilities(needs_components=True).mismatch(tank_traits)
    assert "boolean-affine" in Capabilities(needs_boolean_affine=True).mismatch(tank_traits)
    assert Capabilities(applies_jump_maps=True).mismatch(tank_traits) is None

    class Other(ModelTraits):  # the kinds the loader does not produce yet
        continuous = jumps = components = booleans = True

    other = Other(tank)
    assert Capabilities().mismatch(other) == (
        "needs a discrete-time model; the model's time is continuous"
    )
    flags = {"continuous_time": True, "needs_components": True, "needs_boolean_affine": True}
    assert "does not apply jump maps" in Capabilities(**flags).mismatch(other)
    assert Capabilities(**flags, applies_jump_maps=True).mismatch(other) is None
    assert tank.transitions is None and cart.transitions is not None
    assert "[transitions]" in Capabilities(needs_markov_matrix=True).mismatch(tank_traits)
    assert Capabilities(needs_markov_matrix=True).mismatch(cart_traits) is None
    measured = Capabilities(needs_measured_state=True)
    assert measured.mismatch(tank_traits) == (
        "needs the state measured; modes.2.h is not the state (x1, x2, x3)"
    )
    assert "modes.1.h is not the state (x1, x2, x3, x4)" in measured.mismatch(cart_traits)
    single = Capabilities(needs_single_output=True)
    assert single.mismatch(tank_traits) == (
        "needs a single-output model; the model has 3 outputs (y1, y2, y3)"
    )
    assert single.mismatch(cart_traits) is None
    switching = Capabilities(needs_switching_signal=True)
    assert switching.signals_mismatch(tank, tank_signals) is None
    blind = dataclasses.replace(tank_signals, truth_modes=None)
    assert "--map truth.mode=PATH" in switching.signals_mismatch(tank, blind)


def test_a_log_without_what_the_estimator_needs_is_refused(cases, monkeypatch):
    model, signals = cases["three_tank_hstf"]
    entry = dataclasses.replace(
        ESTIMATORS["hstf"], capabilities=Capabilities(needs_switching_signal=True)
    )
    monkeypatch.setitem(ESTIMATORS, "hstf", entry)
    prepared = prepare(model, "hstf")
    with pytest.raises(LogError, match=r"^simulation: estimator 'hstf' needs the switching"):
        prepared.run(model, dataclasses.replace(signals, truth_modes=None))


def result_fields(n=5, n_modes=2, n_x=3, n_y=1):
    return {
        "estimator": "toy",
        "options": {},
        "time": np.arange(n, dtype=np.float64),
        "mode_ids": tuple(str(i) for i in range(n_modes)),
        "state_names": tuple(f"x{i}" for i in range(n_x)),
        "output_names": tuple(f"y{i}" for i in range(n_y)),
        "modes": np.zeros(n, dtype=np.int64),
        "mode_probabilities": np.full((n, n_modes), 1.0 / n_modes),
        "state_means": np.zeros((n, n_x)),
        "state_variances": np.zeros((n, n_x)),
        "output_predictions": np.zeros((n, n_y)),
    }


@pytest.mark.parametrize(
    "field",
    [
        "modes",
        "mode_probabilities",
        "state_means",
        "state_variances",
        "output_predictions",
        "covariances",
    ],
)
def test_a_result_of_the_wrong_shape_names_estimator_and_field(field):
    fields = result_fields()
    fields["covariances"] = np.zeros((5, 3, 3))
    EstimationResult(**fields)
    fields[field] = np.zeros((4, *fields[field].shape[1:]), dtype=fields[field].dtype)
    with pytest.raises(ResultShapeError, match=rf"^toy: result field '{field}' has shape \(4"):
        EstimationResult(**fields)


def test_a_result_of_the_wrong_dtype_or_mode_names_estimator_and_field():
    fields = result_fields()
    with pytest.raises(ResultShapeError, match=r"^toy: result field 'modes' has dtype float64"):
        EstimationResult(**{**fields, "modes": np.zeros(5)})
    with pytest.raises(ResultShapeError, match=r"^toy: result field 'state_means' has dtype"):
        EstimationResult(**{**fields, "state_means": np.zeros((5, 3), dtype=np.float32)})
    with pytest.raises(ResultShapeError, match=r"'modes' holds mode indices outside \[0, 2\)"):
        EstimationResult(**{**fields, "modes": np.array([0, 1, 2, 0, 0])})
    with pytest.raises(ResultShapeError, match=r"^toy: result field 'time' has shape \(5, 1\)"):
        EstimationResult(**{**fields, "time": np.zeros((5, 1))})
    with pytest.raises(ResultShapeError, match="'output_predictions' has shape list"):
        EstimationResult(**{**fields, "output_predictions": [[0.0]] * 5})


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("notes", "one remark"),  # ("one remark") without its comma
        ("notes", ("a", 1)),
        ("mode_ids", "12"),
        ("state_names", "abc"),
        ("output_names", ("y1", None, "y3")),
        ("options", None),
    ],
)
def test_a_result_with_names_notes_or_options_of_the_wrong_type_is_refused(field, value):
    # notes="one remark" passed as the characters of the text: report.json's notes were
    # ["o", "n", "e", ...]; mode_ids="12" passed for two modes.
    fields = result_fields()
    with pytest.raises(ResultShapeError, match=rf"^toy: result field '{field}' must be a "):
        EstimationResult(**{**fields, field: value})


# The recipe of docs/architecture.md, followed by a test: this module holds an estimator
# (options + run), one registry entry names it, and `analyze` writes its report unchanged.


@dataclasses.dataclass(frozen=True)
class PersistOptions:
    lag: int = option(1, "predict y(k) as y(k - lag)", range=(1, 10))


def run_persist(model, signals, options):
    """Naive persistence: the prior's mode and state throughout, ŷ(k) = y(k − lag)."""
    n = signals.n_samples
    predictions = np.full(signals.outputs.shape, np.nan)
    predictions[options.lag :] = signals.outputs[: n - options.lag]
    prior = model.initial_mode_probabilities
    return EstimationResult(
        estimator="persist",
        options=options_dict(options),
        time=signals.time,
        mode_ids=model.mode_ids,
        state_names=model.states,
        output_names=model.outputs,
        modes=np.full(n, int(np.argmax(prior)), dtype=np.int64),
        mode_probabilities=np.tile(prior, (n, 1)),
        state_means=np.tile(model.initial_state, (n, 1)),
        state_variances=np.tile(np.diag(model.initial_covariance), (n, 1)),
        output_predictions=predictions,
    )


def test_a_new_estimator_is_one_module_and_one_registry_entry(tmp_path, monkeypatch):
    entry = Estimator(
        name="persist",
        summary="naive persistence",
        source="none",
        module=__name__,
        options="PersistOptions",
        run="run_persist",
        # its first `lag` samples have no prediction (NaN): said, or the run is refused
        capabilities=Capabilities(unpredicted_outputs=True),
    )
    monkeypatch.setitem(ESTIMATORS, "persist", entry)
    outcome = analyze(
        SAMPLE, "three_tank_hstf", estimator="persist", sets=["lag=2"], out_dir=tmp_path / "r"
    )
    report = json.loads((tmp_path / "r" / "report.json").read_text())
    assert report["estimator"] == "persist" and report["options"] == {"lag": 2}
    assert outcome.report.modes.accuracy is not None
    assert "lag=1  int, in [1, 10]  predict y(k) as y(k - lag)" in entry.help_text()


def run_unechoed(model, signals, options):
    """:func:`run_persist` whose result leaves the options out and names no estimator."""
    return dataclasses.replace(run_persist(model, signals, options), estimator="", options={})


def test_the_registry_writes_the_options_an_estimator_left_out_of_its_result(tmp_path, monkeypatch):
    # The recipe asks of an estimator's module only run(model, signals, options): one that
    # did not echo its options wrote "options": {} into report.json, its --set lost.
    entry = Estimator(
        name="unechoed",
        summary="naive persistence, options not echoed",
        source="none",
        module=__name__,
        options="PersistOptions",
        run="run_unechoed",
        capabilities=Capabilities(unpredicted_outputs=True),
    )
    monkeypatch.setitem(ESTIMATORS, "unechoed", entry)
    analyze(SAMPLE, "three_tank_hstf", estimator="unechoed", sets=["lag=2"], out_dir=tmp_path / "r")
    report = json.loads((tmp_path / "r" / "report.json").read_text())
    assert report["estimator"] == "unechoed" and report["options"] == {"lag": 2}


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        (
            model_kinds.CONTINUOUS_TANK,
            "needs a discrete-time model; the model's time is continuous",
        ),
        (model_kinds.CLUTCH_JUMPS, "model's time is continuous"),
    ],
)
def test_models_of_kinds_no_estimator_handles_yet_are_refused_before_reading(text, reason):
    model = parse_model(text, origin="kind.toml")
    for name in ("hstf", "imm"):
        with pytest.raises(HybridlogError, match=reason) as caught:
            prepare(model, name)
        assert "kind.toml" in str(caught.value)
        assert "\n" not in str(caught.value)


def test_every_estimator_a_model_is_said_to_suit_runs_on_it(cases):
    """The refusal's list "(estimators for this model: ...)" is the list that runs.

    Each model case against each estimator: either :meth:`Capabilities.mismatch` names a
    reason, or preparing and running it on the case's log succeeds (a ``[components]``
    model once crashed ``hstf``, ``chiu`` and ``kmeans``, which the refusal listed).
    """
    for model_name, (model, signals) in cases.items():
        traits = ModelTraits(model)
        for name, entry in ESTIMATORS.items():
            capabilities = entry.capabilities
            if capabilities.mismatch(traits) or capabilities.signals_mismatch(model, signals):
                with pytest.raises(HybridlogError):
                    prepare(model, name).run(model, signals)
                continue
            result = prepare(model, name).run(model, signals)
            assert result.n_samples == signals.n_samples, (model_name, name)


def test_a_components_model_too_large_to_enumerate_is_refused_before_reading():
    model = load_model("bioplex_pgc")
    suited = [
        n for n, e in ESTIMATORS.items() if e.capabilities.mismatch(ModelTraits(model)) is None
    ]
    assert suited == ["unknown-mode"]
    with pytest.raises(ModelError, match=r"joint modes, at most 256; the model has 288"):
        prepare(model, "imm")
    for name in ("hstf", "chiu", "kmeans"):
        with pytest.raises(ModelError, match=r"describes concurrent \[components\]") as caught:
            prepare(model, name)
        assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    ("name", "sets"),
    [("imm", {"smooth": "true"}), ("imm", {"mode_sequence": "kbest"}), ("hstf", {})],
    ids=["imm-smooth", "imm-kbest", "hstf"],
)
def test_a_model_of_many_modes_runs_on_the_compiled_loops(name: str, sets: dict[str, str]):
    """30 modes: straight-line code took minutes to compile, then overflowed the recursion
    limit (an unexpected RecursionError); beyond MAX_UNROLLED_MODES the loops run it.

    One case a test: each compiles generic loops of its own (a minute or two each in a cold
    cache), which the test workers then compile side by side."""
    from hybridlog.estimators.unrolled import MAX_UNROLLED_MODES, fits_unrolled

    modes = "".join(
        f'[modes.m{i}]\nf = ["{0.5 + 0.4 * i / 30:.3f}*x + u"]\nh = ["x"]\n' for i in range(30)
    )
    model = parse_model(
        'name = "many"\ntime = "discrete"\ndt = 1.0\nstates = ["x"]\ninputs = ["u"]\n'
        f'outputs = ["y"]\n{modes}[noise]\nprocess = 0.1\nmeasurement = 0.1\n'
        '[initial]\nstate = [0.0]\ncovariance = 1.0\nmode = "m0"\n'
        '[simulation]\nstate = [0.0]\nschedule = "m0:30,m29:30"\n'
        '[simulation.inputs]\nu = "sin(0.1*t)"\n'
    )
    assert model.n_modes > MAX_UNROLLED_MODES and not fits_unrolled(model)
    signals = simulate(model, steps=60, seed=1).signals(model)
    result = prepare(model, name, sets).run(model, signals)
    assert result.n_samples == signals.n_samples and np.isfinite(result.state_means).all()


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_a_log_of_no_sample_is_an_empty_result_or_a_one_line_error(name, cases):
    # sliding-mode and unknown-mode indexed the first row: IndexError from Prepared.run
    model, signals = cases[model_for(name)]
    try:
        result = prepare(model, name).run(model, signals.rows(0, 0))
    except HybridlogError as error:
        assert "\n" not in str(error)
    else:
        assert result.modes.shape == (0,) and result.state_means.shape == (0, model.n_states)


def _given_as(signals, kind):
    """``signals`` with inputs and outputs as a caller of the library may hold them."""
    if kind == "lists":
        return dataclasses.replace(
            signals, inputs=signals.inputs.tolist(), outputs=signals.outputs.tolist()
        )
    if kind == "strided":  # every other row of arrays twice as long, in Fortran order
        return dataclasses.replace(
            signals,
            inputs=np.asfortranarray(np.repeat(signals.inputs, 2, axis=0))[::2],
            outputs=np.asfortranarray(np.repeat(signals.outputs, 2, axis=0))[::2],
        )
    inputs, outputs = signals.inputs.copy(), signals.outputs.copy()
    inputs.flags.writeable = outputs.flags.writeable = False
    return dataclasses.replace(signals, inputs=inputs, outputs=outputs)


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_signals_as_lists_strided_or_read_only_arrays_give_the_same_result(name, cases, runs):
    # chiu and kmeans took a list for an array (AttributeError), sliding-mode's compiled
    # code refused a read-only array (numba's TypeError)
    model, signals = cases[model_for(name)]
    prepared, result, _ = runs[name]
    for kind in ("lists", "strided", "read-only"):
        given = prepared.run(model, _given_as(signals, kind))
        np.testing.assert_array_equal(given.modes, result.modes, err_msg=kind)
        np.testing.assert_array_equal(given.state_means, result.state_means, err_msg=kind)
    if ESTIMATORS[name].capabilities.supports_smoothing:  # the offline pass reads them too
        smoothed = prepare(model, name, {"smooth": True})
        listed = smoothed.run(model, _given_as(signals, "lists"))
        np.testing.assert_array_equal(listed.modes, smoothed.run(model, signals).modes)


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_an_input_or_output_that_is_not_finite_is_a_log_error_naming_it(name, cases):
    # kmeans let SciPy's "array must not contain infs or NaNs" through; the filters called
    # it a divergence of their own
    model, signals = cases[model_for(name)]
    outputs = signals.outputs.copy()
    outputs[5, 0] = np.nan
    with pytest.raises(LogError, match=rf"outputs: {model.outputs[0]} = nan at t = .* \(row 5\)"):
        prepare(model, name).run(model, dataclasses.replace(signals, outputs=outputs))


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_signals_aligned_for_another_model_are_refused(name, cases):
    # imm of the three-tank model ran on the double cart's signals (outputs y for y1, y2,
    # y3): its compiled loop read three columns of a one-column array and gave a result
    model, _ = cases[model_for(name)]
    other = "three_tank_hstf" if model_for(name) == "double_cart_case1" else "double_cart_case1"
    _, signals = cases[other]
    with pytest.raises(LogError, match="signals aligned for another model"):
        prepare(model, name).run(model, signals)


@pytest.mark.parametrize(
    ("name", "overrides", "shown"),
    [
        (3, None, "--estimator: expected an estimator's name, got the int '3'"),
        ("imm", ["smooth=true"], r"--set: expected a mapping .* got the list '\['smooth=true'\]'"),
        ("imm", {1: "x"}, "--set: expected a mapping of option names to values, got the dict"),
    ],
)
def test_prepare_refuses_arguments_of_the_wrong_type(name, overrides, shown, cases):
    # AttributeError: 'int' object has no attribute 'casefold', 'list' ... no attribute 'items'
    model, _ = cases["three_tank_hstf"]
    with pytest.raises(OptionError, match=shown):
        prepare(model, name, overrides)
