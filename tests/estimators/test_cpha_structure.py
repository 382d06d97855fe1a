"""Structural analysis of paper 002's three-component example (eqs. (2)-(3), Figs. 6-10)."""

import pytest
import sympy

from hybridlog.errors import ModelError
from hybridlog.estimators.cpha.structure import StructureCache, decompose, virtual_input
from hybridlog.model.loader import parse_model

# Paper 002 eq. (2): F1(m11), F2(m21), F3(m31) as a [components] model.  The noise values
# are ours (the paper gives none for this example).
PAPER_EXAMPLE = """
name = "paper002_example"
dt = 1.0
states = ["xc1", "xc2", "xc3"]
inputs = ["uc1"]
outputs = ["yc1", "yc2"]
variables = ["wc1"]

[noise]
process = [0.01, 0.02, 0.03]
measurement = [0.5, 0.05]

[initial]
state = [0.0, 0.0, 0.0]
covariance = 1.0

[components.A1]
unknown = 0.01
initial = "m11"

[components.A1.modes.m11]
equations = ["uc1 = 5.0*wc1"]

[components.A2]
unknown = 0.01
initial = "m21"

[components.A2.modes.m21]
equations = ["xc1[k] = 0.8*xc1[k-1] + wc1[k-1]", "yc1 = xc1"]

[components.A3]
unknown = 0.01
initial = "m31"

[components.A3.modes.m31]
equations = [
  "xc2[k] = xc3[k-1] + yc1[k-1]",
  "xc3[k] = 0.4*xc2[k-1] + 0.5*uc1[k-1]",
  "yc2 = 2.0*xc2 + xc3",
]
"""

UY1 = virtual_input("yc1")


@pytest.fixture(scope="module")
def model():
    return parse_model(PAPER_EXAMPLE)


def analyse(model, *assignment):
    return decompose(
        model.components,
        assignment,
        states=model.states,
        inputs=model.inputs,
        outputs=model.outputs,
        variables=model.variables,
    )


def x(name):
    return sympy.Symbol(name, real=True)


def test_causal_graph_of_the_full_mode_is_fig_6(model):
    d = analyse(model, "m11", "m21", "m31")
    # Fig. 6: uc1 -> wc1 -> xc1 -> yc1 -> xc2 <-> xc3 <- uc1, and xc2, xc3 -> yc2.
    assert d.causal_graph.edges == {
        ("uc1", "wc1"),
        ("wc1", "xc1"),
        ("xc1", "yc1"),
        ("yc1", "xc2"),
        ("xc3", "xc2"),
        ("xc2", "xc3"),
        ("uc1", "xc3"),
        ("xc2", "yc2"),
        ("xc3", "yc2"),
    }
    assert d.causal_graph.exogenous == {"uc1"}
    # Fig. 7: only yc1 has an outgoing edge; it moves to the virtual input uy_c1.
    assert ("yc1", "xc2") not in d.sliced_graph.edges
    assert (UY1, "xc2") in d.sliced_graph.edges
    assert d.sliced_graph.edges - {(UY1, "xc2")} == d.causal_graph.edges - {("yc1", "xc2")}


def test_full_mode_gives_the_two_filters_of_figs_4_and_5(model):
    d = analyse(model, "m11", "m21", "m31")
    first, second = d.clusters
    # Filter 1: A1 and A2 (x_c1 from u_c1 and y_c1), with f = eq. (3)'s first row.
    assert (first.states, first.outputs, first.inputs, first.virtual_inputs) == (
        ("xc1",),
        ("yc1",),
        ("uc1",),
        (),
    )
    assert first.components == ("A1", "A2")
    assert sympy.simplify(first.f[0] - (0.8 * x("xc1") + 0.2 * x("uc1"))) == 0
    assert first.h == (x("xc1"),)
    # Filter 2: A3 with the measurement y_c1 as its input.
    assert second.states == ("xc2", "xc3") and second.outputs == ("yc2",)
    assert second.inputs == ("uc1",) and second.virtual_inputs == ("yc1",)
    assert second.components == ("A3",)
    assert sympy.simplify(second.f[0] - (x("xc3") + x("yc1"))) == 0
    assert sympy.simplify(second.f[1] - (0.4 * x("xc2") + 0.5 * x("uc1"))) == 0
    assert sympy.simplify(second.h[0] - (2.0 * x("xc2") + x("xc3"))) == 0
    # eq. (6): r_1 is y_c1's sensor variance.
    assert second.virtual_noise == (0.5,) and second.process_noise == (0.02, 0.03)
    assert d.held_states == () and d.rejected == ()


def test_unknown_first_component_fig_8_to_10(model):
    d = analyse(model, "unknown", "m21", "m31")
    # Fig. 8: without F1, w_c1 has no incoming edge: an exogenous variable that is no input.
    assert d.causal_graph.exogenous == {"uc1", "wc1"}
    assert ("uc1", "wc1") not in d.causal_graph.edges
    assert ("wc1", "xc1") in d.causal_graph.edges
    # Fig. 9: the SCCs; x_c2 and x_c3 form the only loop.
    assert set(d.sccs) == {
        frozenset({"xc2", "xc3"}),
        frozenset({"xc1"}),
        frozenset({"yc1"}),
        frozenset({"yc2"}),
        frozenset({"wc1"}),
        frozenset({"uc1"}),
        frozenset({UY1}),
    }
    sod = {
        frozenset(s): (o, det, i)
        for s, o, det, i in zip(d.sccs, d.observable, d.determined, d.cluster_indices, strict=True)
    }
    # Fig. 10: {yc1, xc1} is observable but undetermined (w_c1 unknown); {yc2, xc2 xc3} is
    # observable and determined (u_c1 and the virtual input u_yc1 are known).
    assert sod[frozenset({"yc1"})][:2] == (True, False)
    assert sod[frozenset({"xc1"})][:2] == (True, False)
    assert sod[frozenset({"yc2"})][:2] == (True, True)
    assert sod[frozenset({"xc2", "xc3"})][:2] == (True, True)
    assert sod[frozenset({"wc1"})][1] is False
    assert sod[frozenset({UY1})][1] is True and sod[frozenset({"uc1"})][1] is True
    assert sod[frozenset({"xc1"})][2] == sod[frozenset({"yc1"})][2]
    assert sod[frozenset({"xc1"})][2] != sod[frozenset({"xc2", "xc3"})][2]
    # The filter cluster is the one filter for A3 (Fig. 4); x_c1 is held.
    (cluster,) = d.clusters
    assert cluster.states == ("xc2", "xc3") and cluster.outputs == ("yc2",)
    assert cluster.components == ("A3",) and cluster.virtual_inputs == ("yc1",)
    assert d.rejected == ("yc1",) and d.held_states == ("xc1",)


def test_unknown_third_component_leaves_the_first_filter(model):
    d = analyse(model, "m11", "m21", "unknown")
    (cluster,) = d.clusters
    assert cluster.states == ("xc1",) and cluster.components == ("A1", "A2")
    assert d.held_states == ("xc2", "xc3") and d.rejected == ()


def test_decompositions_are_cached_per_assignment(model):
    cache = StructureCache(
        model.components,
        states=model.states,
        inputs=model.inputs,
        outputs=model.outputs,
        variables=model.variables,
    )
    a = cache.get(("m11", "m21", "m31"))
    assert cache.get(("m11", "m21", "m31")) is a
    cache.get(("unknown", "m21", "m31"))
    assert (cache.hits, cache.misses) == (1, 2)


def test_an_equation_sympy_cannot_solve_is_named():
    text = PAPER_EXAMPLE.replace("uc1 = 5.0*wc1", "uc1 = sign(wc1)")
    model = parse_model(text)
    with pytest.raises(ModelError, match=r"components\.A1\.modes\.m11\.equations\[0\]: cannot"):
        analyse(model, "m11", "m21", "m31")


UNGIVEN = PAPER_EXAMPLE.replace('variables = ["wc1"]', 'variables = ["wc1", "wc2"]').replace(
    '"yc1 = xc1"', '"yc1 = xc1 + wc2"'
)
"""The example with a variable ``wc2`` that A2's output uses and no equation gives."""

UNGIVEN_ERROR = (
    r"components\.A2\.modes\.m21\.equations\[1\]: uses '(wc2|yc1)', which no equation "
    r"of the joint mode m11\|m21\|m31 determines"
)


def unchecked_model(text, monkeypatch):
    """``text`` parsed as past the bound of the check made when a file is read.

    :func:`~hybridlog.model.component_structure.check_joint_modes` refuses such a file
    before any estimator sees it; past its bound the estimators' own checks remain.
    """
    import hybridlog.model.loader

    monkeypatch.setattr(hybridlog.model.loader, "check_joint_modes", lambda *_: None)
    return parse_model(text)


def test_a_variable_no_known_mode_gives_is_refused_when_the_file_is_read():
    with pytest.raises(ModelError, match=r"^<model>: " + UNGIVEN_ERROR):
        parse_model(UNGIVEN)


def test_a_variable_no_known_mode_gives_is_refused_not_dropped(monkeypatch):
    # The cluster of yc1 was dropped without a word (wc2 "undetermined", as if a component
    # were unknown): a report of no estimated state and every mode "right".
    model = unchecked_model(UNGIVEN, monkeypatch)
    with pytest.raises(ModelError, match=UNGIVEN_ERROR):
        analyse(model, "m11", "m21", "m31")
    d = analyse(model, "unknown", "m21", "m31")  # an unknown component leaves it so: paper's case
    assert d.held_states == ("xc1",)


def test_joint_modes_refuse_a_variable_no_mode_gives(monkeypatch):
    # imm's joint mode kept wc2 as a free symbol of h: numba's NameError at run time.
    from hybridlog.estimators.cpha.joint import joint_mode_model

    with pytest.raises(ModelError, match=r"^<model>: " + UNGIVEN_ERROR):
        joint_mode_model(unchecked_model(UNGIVEN, monkeypatch))
