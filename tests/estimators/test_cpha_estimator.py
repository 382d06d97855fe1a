"""Hybrid estimation with unknown modes (paper 002 eqs. (4)-(5)) and the estimator's result."""

import dataclasses
import itertools
import math

import numpy as np
import pytest
import sympy

from hybridlog.errors import LogError
from hybridlog.estimators import prepare
from hybridlog.estimators.cpha.hypotheses import Hypothesis
from hybridlog.estimators.cpha.options import UnknownModeOptions
from hybridlog.estimators.cpha.unknown_mode import make_tracker, run_unknown_mode
from hybridlog.model.components import UNKNOWN
from hybridlog.model.loader import parse_model
from tests.support.cpha import CPHA_EXAMPLE, cpha_log


@pytest.fixture(scope="module")
def model():
    return parse_model(CPHA_EXAMPLE)


def known_transition_log(component, source, target):
    """log P_T(target | source) with the unknown mode removed and the rest renormalised."""
    p = component.transition_probabilities(source)
    p.pop(UNKNOWN, None)
    return math.log(p[target] / sum(p.values())) if target in p else -math.inf


def enumerate_trajectories(model, tracker, steps):
    """Every trajectory of every known joint mode (no pruning), step by step.

    Yields, for k = 1 … steps-1, the list of ``(hypothesis, history)`` at step k, where the
    history is the trajectory's joint assignments from step 0 and the beliefs are the
    unnormalised log posteriors (prior transitions times ``P_O``, eq. (5) before normalising).
    """
    assignments = list(itertools.product(*(c.mode_ids for c in model.components)))
    start = tuple(c.mode_ids[0] for c in model.components)  # the initial modes (all known)
    nan = np.full(model.n_outputs, np.nan)
    first = Hypothesis(start, 0.0, model.initial_state.copy(), model.initial_covariance.copy(), nan)
    trajectories = [(first, [start])]
    for k in range(1, steps):
        extended = []
        for parent, history in trajectories:
            for a in assignments:
                prior = parent.log_belief + sum(
                    known_transition_log(c, s, t)
                    for c, s, t in zip(model.components, parent.assignment, a, strict=True)
                )
                if prior == -math.inf:
                    continue
                child = tracker.successor(parent, a, k)
                child.log_belief += prior
                extended.append((child, [*history, a]))
        trajectories = extended
        yield trajectories


def exhaustive(model, tracker, steps):
    """The most likely trajectory's (assignment, normalised log belief, x) per step."""
    best = []
    for trajectories in enumerate_trajectories(model, tracker, steps):
        beliefs = [h.log_belief for h, _ in trajectories]
        top = max(beliefs)
        total = top + math.log(sum(math.exp(b - top) for b in beliefs))
        winner = max(trajectories, key=lambda pair: pair[0].log_belief)[0]
        best.append((winner.assignment, winner.log_belief - total, winner.x))
    n_assignments = math.prod(len(c.mode_ids) for c in model.components)
    return best, n_assignments


def test_a_wide_beam_finds_the_most_likely_joint_mode_of_the_exhaustive_enumeration(model):
    steps = 6
    signals = cpha_log(model, steps, seed=2, a2=lambda k: "m22" if k >= 3 else "m21")
    options = UnknownModeOptions(beam=4**5, candidates=10**6, unknown_mode=False)
    reference, n_assignments = exhaustive(model, make_tracker(model, signals, options), steps)
    assert n_assignments == 4
    tracker = make_tracker(model, signals, options)
    hypotheses = tracker.start(model.initial_state, model.initial_covariance)
    assert [h.assignment for h in hypotheses] == [("m11", "m21", "m31")]
    for k in range(1, steps):
        hypotheses = tracker.step(hypotheses, k)
        assert len(hypotheses) == 4**k  # the beam holds every trajectory
        assignment, log_belief, x = reference[k - 1]
        assert hypotheses[0].assignment == assignment
        assert hypotheses[0].log_belief == pytest.approx(log_belief, abs=1e-9)
        np.testing.assert_allclose(hypotheses[0].x, x, atol=1e-12)


def test_a_narrow_beam_proposes_few_successors_and_keeps_beam_hypotheses(model):
    signals = cpha_log(model, 40, seed=4)
    tracker = make_tracker(model, signals, UnknownModeOptions(beam=3))
    hypotheses = tracker.start(model.initial_state, model.initial_covariance)
    for k in range(1, 40):
        hypotheses = tracker.step(hypotheses, k)
        assert len(hypotheses) == 3
        beliefs = [h.log_belief for h in hypotheses]
        assert beliefs == sorted(beliefs, reverse=True)
        assert sum(math.exp(b) for b in beliefs) == pytest.approx(1.0)
    # 3 parents x 3^3 successor assignments each are never all filtered.
    assert tracker.proposed < 39 * 3 * 27 / 4


def test_unknown_mode_detects_an_unmodelled_drift_and_without_it_the_drift_is_misread(model):
    drift = cpha_log(model, 150, seed=1, a1=lambda k: "drift" if 60 <= k < 100 else "m11")
    result = run_unknown_mode(model, drift, UnknownModeOptions(beam=10))
    columns = {c.name: c for c in result.timeline_columns}
    a1 = columns["mode.A1"]
    assert a1.labels == ("m11", "m12", UNKNOWN)
    is_unknown = a1.values == a1.labels.index(UNKNOWN)
    assert not is_unknown[:60].any()
    assert is_unknown[70:100].mean() >= 0.8
    p_unknown = columns["p_unknown.A1"].values
    assert p_unknown[75:100].min() > 0.5 and p_unknown[:55].max() < 0.5
    assert all(label.count("|") == 2 for label in result.mode_ids)
    np.testing.assert_allclose(result.mode_probabilities.sum(axis=1), 1.0)
    assert "decompositions:" in result.notes[0] and "hit rate" in result.notes[0]

    closed = run_unknown_mode(model, drift, UnknownModeOptions(beam=10, unknown_mode=False))
    assert not any(UNKNOWN in label for label in closed.mode_ids)
    a1_closed = {c.name: c for c in closed.timeline_columns}["mode.A1"]
    assert not (a1_closed.values == 2).any()
    # the states stay estimated throughout: no state is held
    assert np.isfinite(closed.output_predictions[1:]).all()


def test_the_registry_runs_it_on_a_components_model_only(model):
    prepared = prepare(model, "unknown-mode", {"beam": "5"})
    assert prepared.options.beam == 5 and prepared.options.unknown_mode is True
    signals = cpha_log(model, 30, seed=3)
    result = prepared.run(model, signals)
    assert result.estimator == "unknown-mode" and result.n_samples == 30
    assert result.options["beam"] == 5


def test_the_report_draws_one_timeline_per_component(model, tmp_path):
    from hybridlog.report.mode_plots import plot_components
    from hybridlog.report.plot_reducer import reduce_result
    from hybridlog.report.plots import write_plots

    signals = cpha_log(model, 40, seed=3, a1=lambda k: "drift" if k >= 20 else "m11")
    result = run_unknown_mode(model, signals, UnknownModeOptions(beam=5))
    written = write_plots(tmp_path, result, signals)
    assert [p.name for p in written] == ["outputs.png", "modes.png", "states.png"]
    assert (tmp_path / "modes.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bare = dataclasses.replace(result, timeline_columns=())
    assert plot_components(reduce_result(bare, signals), tmp_path / "none.png") is None
    assert not (tmp_path / "none.png").exists()


def test_imm_runs_on_the_enumerated_joint_modes_and_agrees_where_it_should(model):
    from hybridlog.estimators.cpha.joint import joint_mode_model
    from hybridlog.estimators.imm import ImmOptions, run_imm

    joint = joint_mode_model(model)
    assert joint.mode_ids == ("m11|m21|m31", "m11|m22|m31", "m12|m21|m31", "m12|m22|m31")
    x1, x2, x3, u1 = (sympy.Symbol(n, real=True) for n in ("xc1", "xc2", "xc3", "uc1"))
    full = joint.modes[0]  # eq. (3): the MIMO model of [m11, m21, m31]
    expected = (0.8 * x1 + 0.2 * u1, x1 + x3, 0.4 * x2 + 0.5 * u1)
    assert all(sympy.simplify(a - b) == 0 for a, b in zip(full.f, expected, strict=True))
    assert all(sympy.simplify(a - b) == 0 for a, b in zip(full.h, (x1, 2.0 * x2 + x3), strict=True))
    np.testing.assert_allclose(joint.transitions.sum(axis=1), 1.0)
    np.testing.assert_array_equal(joint.initial_mode_probabilities, [1.0, 0.0, 0.0, 0.0])

    signals = cpha_log(model, 200, seed=1, a2=lambda k: "m22" if 80 <= k < 140 else "m21")
    imm = run_imm(model, signals, ImmOptions())
    beam = run_unknown_mode(model, signals, UnknownModeOptions(beam=20, unknown_mode=False))
    settled = np.r_[20:75, 100:135, 165:200]  # well inside each true segment
    truth = np.where((np.arange(200) >= 80) & (np.arange(200) < 140), 1, 0)
    for result in (imm, beam):
        labels = np.array([result.mode_ids[i] for i in result.modes])
        assert np.mean(labels[settled] == np.array(joint.mode_ids)[truth[settled]]) >= 0.95


def test_a_component_starting_unknown_starts_in_its_known_modes_when_unknown_is_off():
    text = CPHA_EXAMPLE.replace(
        '[components.A3]\nunknown = 0.001\ninitial = "m31"',
        '[components.A3]\nunknown = 0.001\ninitial = "unknown"',
    )
    model = parse_model(text)
    assert model.components[2].initial_mode_probabilities["unknown"] == 1.0
    signals = cpha_log(model, 10, seed=1)
    off = run_unknown_mode(model, signals, UnknownModeOptions(beam=4, unknown_mode=False))
    assert all(label.endswith("|m31") for label in off.mode_ids)
    on = run_unknown_mode(model, signals, UnknownModeOptions(beam=4))
    assert on.mode_ids[on.modes[0]].endswith("|unknown")


def exhaustive_history(model, tracker, steps):
    """The assignments, at every step, of the most likely whole trajectory (no pruning)."""
    *_, last = enumerate_trajectories(model, tracker, steps)
    return max(last, key=lambda pair: pair[0].log_belief)[1]


def test_kbest_with_a_beam_keeping_everything_is_the_most_likely_whole_trajectory(model):
    """The offline mode sequence is the history of the final winner, found by enumeration;
    on some of these logs the causal per-step winner differs from it (so the test is one the
    per-step modes fail)."""
    steps, differs = 6, 0
    options = UnknownModeOptions(beam=4**5, candidates=10**6, unknown_mode=False)
    offline = dataclasses.replace(options, mode_sequence="kbest")
    for seed in range(8):
        signals = cpha_log(model, steps, seed=seed, a2=lambda k: "m22" if k >= 3 else "m21")
        exact = exhaustive_history(model, make_tracker(model, signals, options), steps)
        result = run_unknown_mode(model, signals, offline)
        assert [result.mode_ids[m] for m in result.modes] == ["|".join(a) for a in exact]
        filtered = result.post_processing.filtered
        differs += filtered.modes.tolist() != result.modes.tolist()
        # the last sample is the final winner's, as the causal estimate's
        assert result.modes[-1] == filtered.modes[-1]
        np.testing.assert_array_equal(result.state_means[-1], filtered.state_means[-1])
    assert differs > 0


# CPHA_EXAMPLE with `unknown` left with probability 0.6 per step and A3 reading x_c1 (not its
# measurement y_c1): w_c1 then reaches every state, so A1 (or A2) in `unknown` leaves both
# outputs unchecked, and staying there (log 0.4 = -0.92 a step) costs less than a fitting
# known mode's expected log P_O (-1/2 per output, -1): docs/smoothing.md.
LEFT_READILY = (
    CPHA_EXAMPLE.replace("to = {m11 = 0.25, m12 = 0.25}", "to = {m11 = 0.3, m12 = 0.3}")
    .replace("to = {m21 = 0.25, m22 = 0.25}", "to = {m21 = 0.3, m22 = 0.3}")
    .replace("to = {m31 = 0.5}", "to = {m31 = 0.6}")
    .replace('"xc2[k] = xc3[k-1] + yc1[k-1]"', '"xc2[k] = xc3[k-1] + xc1[k-1]"')
)


def transition_log(component, source, target):
    """log P_T(target | source), the unknown mode included."""
    p = component.transition_probabilities(source).get(target, 0.0)
    return math.log(p) if p > 0.0 else -math.inf


def path_log_probability(model, tracker, path):
    """Σ_k log P_T + log P_O (eq. (5) unnormalised) of a whole path from the initial modes."""
    nan = np.full(model.n_outputs, np.nan)
    h = Hypothesis(path[0], 0.0, model.initial_state.copy(), model.initial_covariance.copy(), nan)
    total = 0.0
    for k in range(1, len(path)):
        total += sum(
            transition_log(c, s, t)
            for c, s, t in zip(model.components, path[k - 1], path[k], strict=True)
        )
        h = tracker.successor(h, path[k], k)
        total += h.log_belief
    return total


def most_likely_path_log_probability(model, tracker, steps):
    """The largest :func:`path_log_probability` over every path of every assignment.

    Depth first, unknown mode included; log P_T ≤ 0 and log P_O ≤ 0, so a prefix that
    scores below the best whole path found so far bounds all its extensions (branch and
    bound: exact, as the enumeration of every path, in a second).
    """
    modes = [(*c.mode_ids, UNKNOWN) for c in model.components]
    assignments = list(itertools.product(*modes))
    start = tuple(c.mode_ids[0] for c in model.components)
    nan = np.full(model.n_outputs, np.nan)
    first = Hypothesis(start, 0.0, model.initial_state.copy(), model.initial_covariance.copy(), nan)
    best = -math.inf

    def extend(parent, score, k):
        nonlocal best
        if k == steps:
            best = max(best, score)
            return
        children = []
        for a in assignments:
            prior = score + sum(
                transition_log(c, s, t)
                for c, s, t in zip(model.components, parent.assignment, a, strict=True)
            )
            if prior > best:
                child = tracker.successor(parent, a, k)
                children.append((prior + child.log_belief, child))
        for total, child in sorted(children, key=lambda pair: -pair[0]):
            if total > best:
                extend(child, total, k + 1)

    extend(first, 0.0, 1)
    return best


def test_kbest_with_the_unknown_mode_is_the_most_likely_whole_trajectory():
    """Where the path sits in ``unknown`` (A1 drifts from step 4), it is the model's most
    likely trajectory over every path of every assignment with ``unknown``, not a search
    or read-back artefact: its log probability, scored by the enumeration's own function, is
    the enumeration's largest; the causal per-step modes differ from it."""
    model = parse_model(LEFT_READILY)
    steps = 12
    for seed in (0, 3):
        drift = cpha_log(model, steps, seed=seed, a1=lambda k: "drift" if k >= 4 else "m11")
        result = run_unknown_mode(model, drift, UnknownModeOptions(mode_sequence="kbest"))
        path = [tuple(result.mode_ids[m].split("|")) for m in result.modes]
        tracker = make_tracker(model, drift, UnknownModeOptions())
        best = most_likely_path_log_probability(model, tracker, steps)
        assert path_log_probability(model, tracker, path) == pytest.approx(best, abs=1e-9)
        assert sum(UNKNOWN in a for a in path) >= 5
        assert result.post_processing.filtered.modes.tolist() != result.modes.tolist()


def test_kbest_reads_the_histories_back_and_keeps_the_causal_predictions(model):
    drift = cpha_log(model, 150, seed=1, a1=lambda k: "drift" if 60 <= k < 100 else "m11")
    filtered = run_unknown_mode(model, drift, UnknownModeOptions(beam=10))
    result = run_unknown_mode(model, drift, UnknownModeOptions(beam=10, mode_sequence="kbest"))
    extra = result.post_processing
    assert extra.smoothing is None and extra.mode_sequence == "kbest"
    assert "10 trajectories" in extra.description
    # the filter's own result is the run without the option, bit for bit
    np.testing.assert_array_equal(extra.filtered.modes, filtered.modes)
    np.testing.assert_array_equal(extra.filtered.state_means, filtered.state_means)
    np.testing.assert_array_equal(result.output_predictions, filtered.output_predictions)
    np.testing.assert_array_equal(result.mode_probabilities, filtered.mode_probabilities)
    # the component timelines follow the path's joint modes
    a1 = {c.name: c for c in result.timeline_columns}["mode.A1"]
    joint = [result.mode_ids[m].split("|")[0] for m in result.modes]
    assert [a1.labels[v] for v in a1.values] == joint
    # a path has one mode per sample, every step an allowed transition (prior > 0)
    (component_a1,) = [c for c in model.components if c.name == "A1"]
    for source, target in itertools.pairwise(joint):
        assert component_a1.transition_probabilities(source).get(target, 0.0) > 0.0


def test_a_cluster_whose_jacobian_is_infinite_is_a_one_line_error_naming_the_key(model):
    """``yc1 = sqrt(xc1)``: a root whose derivative divides by zero where xc1 is 0."""
    from hybridlog.errors import ModelError

    signals = cpha_log(model, 40, seed=3)
    bent = parse_model(
        CPHA_EXAMPLE.replace(
            '"xc1[k] = 0.8*xc1[k-1] + wc1[k-1]", "yc1 = xc1"',
            '"xc1[k] = 0*xc1[k-1]", "yc1 = sqrt(xc1)"',
        ),
        origin="bent.toml",
    )
    with pytest.raises(ModelError, match=r"^bent\.toml: components: at t = .* cannot step") as info:
        run_unknown_mode(bent, signals, UnknownModeOptions())
    assert "\n" not in str(info.value)
    # where it failed: the state before the step and the measurement (a log the model cannot
    # explain, a CO2 sensor at -1e6 ppm, drove a state there; the error named only the model)
    assert " (xc1 = 0 before the step, measured yc1 = " in str(info.value)
    assert "cannot step at sample 1: its equations or their Jacobian are not finite there (" in (
        str(info.value)
    )


def test_an_equation_that_determines_nothing_is_refused_not_dropped(model):
    """``yc1 = 2*xc1`` beside ``yc1 = xc1``: the run ignored it and reported the model's fit."""
    from hybridlog.errors import ModelError

    text = CPHA_EXAMPLE.replace('"yc1 = xc1"', '"yc1 = xc1", "yc1 = 2*xc1"', 1)
    refusal = r"^two\.toml: components\..*equations\[2\]: determines nothing"
    with pytest.raises(ModelError, match=refusal):  # when the file is read, at every joint mode
        parse_model(text, origin="two.toml")
    import hybridlog.model.loader

    with pytest.MonkeyPatch.context() as patch:  # as past the bound of that check
        patch.setattr(hybridlog.model.loader, "check_joint_modes", lambda *_: None)
        contradicting = parse_model(text, origin="two.toml")
    with pytest.raises(ModelError, match=refusal):
        run_unknown_mode(contradicting, cpha_log(model, 20, seed=3), UnknownModeOptions())


def test_a_step_the_candidates_bound_cut_short_is_counted_and_noted(model):
    """``candidates`` below what the beam needs made it approximate without a word: the
    report claimed nothing either way.  A step not counted keeps exactly the unbounded beam."""
    signals = cpha_log(model, 40, seed=4, a1=lambda k: "drift" if k >= 20 else "m11")
    bounded = make_tracker(model, signals, UnknownModeOptions(beam=3, candidates=3))
    exact = make_tracker(model, signals, UnknownModeOptions(beam=3, candidates=10**6))
    hypotheses = bounded.start(model.initial_state, model.initial_covariance)
    differing = 0
    for k in range(1, 40):
        before = bounded.truncated
        kept = bounded.step(hypotheses, k)
        reference = exact.step(hypotheses, k)
        same = [(h.assignment, h.log_belief) for h in kept] == [
            (h.assignment, h.log_belief) for h in reference
        ]
        differing += not same
        if bounded.truncated == before:
            assert same, k
        hypotheses = kept
    assert differing > 0 and exact.truncated == 0
    notes = run_unknown_mode(model, signals, UnknownModeOptions(beam=3, candidates=3)).notes
    assert notes[-1].startswith(
        f"the beam is approximate at {bounded.truncated} of 39 steps: the bound of 3 candidates "
    )
    wide = run_unknown_mode(model, signals, UnknownModeOptions(beam=3, candidates=10**6))
    assert not any("approximate" in note for note in wide.notes)


def test_a_known_mode_no_output_checked_is_warned_of_not_reported_as_an_estimate(model):
    # A1 unknown leaves w_c1 undetermined, so A2's equations (x_c1 from w_c1) sit in no
    # cluster: A2's reported mode is a carry-over there, which the timeline showed silently.
    drift = cpha_log(model, 150, seed=1, a1=lambda k: "drift" if 60 <= k < 100 else "m11")
    result = run_unknown_mode(model, drift, UnknownModeOptions(beam=10))
    columns = {c.name: c for c in result.timeline_columns}
    a1, a2 = columns["mode.A1"], columns["mode.A2"]
    unchecked = (a1.values == a1.labels.index(UNKNOWN)) & (a2.values != a2.labels.index(UNKNOWN))
    assert unchecked.sum() > 20
    (warning,) = [note for note in result.notes if "no output checked" in note]
    first = int(np.argmax(unchecked))
    assert f"A2 on {int(unchecked.sum())} of 150 samples" in warning
    assert f"first at t = {first:g} s" in warning
    assert "A1 on" not in warning and "A3 on" not in warning
    offline = run_unknown_mode(model, drift, UnknownModeOptions(beam=10, mode_sequence="kbest"))
    assert any("A2 on" in note for note in offline.notes)
    clean = cpha_log(model, 60, seed=1)
    assert not any(
        "no output checked" in n
        for n in run_unknown_mode(model, clean, UnknownModeOptions(beam=10)).notes
    )


def test_transition_rules_with_when_apply_by_the_logged_commands():
    # The log's command columns were skipped (a note said the rules with `when` were not
    # applied): a commanded switch (lights off at night) looked like a miss of the estimator.
    commanded = CPHA_EXAMPLE.replace(
        'variables = ["wc1"]', 'variables = ["wc1"]\ncommands = ["a1_cmd"]'
    ).replace(
        '[[components.A1.transitions]]\nfrom = "unknown"',
        '[[components.A1.transitions]]\nfrom = "*"\nwhen = {a1_cmd = 0}\nto = {m12 = 0.9}\n\n'
        '[[components.A1.transitions]]\nfrom = "unknown"',
    )
    model = parse_model(commanded)
    assert any(rule.when for rule in model.components[0].rules)
    signals = cpha_log(model, 20, seed=1)
    refused = r"needs the command 'a1_cmd' in the log, which a transition rule of component 'A1' "
    with pytest.raises(LogError, match=refused):
        run_unknown_mode(model, signals, UnknownModeOptions(beam=5))
    on = dataclasses.replace(signals, command_names=("a1_cmd",), commands=np.ones((20, 1)))
    notes = run_unknown_mode(model, on, UnknownModeOptions(beam=5)).notes
    assert not any("commands are not read" in n for n in notes)
    # a1_cmd = 1 throughout: the rule for 0 never held, which the notes say (no other note)
    (note,) = [n for n in notes if "command" in n]
    assert "never held on this log" in note and "components.A1.transitions[1] (a1_cmd = 0)" in note
