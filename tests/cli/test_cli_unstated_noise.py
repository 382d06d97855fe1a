"""``simulate`` and ``analyze`` refuse a model without measurement noise in one line, exit 2.

Before, a model file without ``[noise] measurement`` simulated outputs with noise of
variance 1 and was analysed by filters weighing the outputs by ``R = I``, both unasked.
"""

from pathlib import Path

from tests.cli.test_cli import run

MODEL = """
name = "quiet"
dt = 0.1
states = ["x"]
outputs = ["y"]

[modes.a]
f = ["0.9*x"]
h = ["x"]

[modes.b]
f = ["0.5*x"]
h = ["x"]

[initial]
state = [1.0]
"""

KEY = "add [noise] measurement (or modes.a.measurement_noise)"


def test_a_model_without_measurement_noise_is_refused_naming_the_key(tmp_path: Path) -> None:
    model = tmp_path / "quiet.toml"
    model.write_text(MODEL, encoding="utf-8")
    log = tmp_path / "quiet.csv"
    sim = ["simulate", str(model), "--out", str(log), "--schedule", "a:10,b:10"]
    refused = run(sim, expect=2)
    assert refused.stderr.count("\n") == 1
    assert f"{model}: noise.measurement: simulate draws" in refused.stderr
    assert KEY in refused.stderr
    assert not log.exists()
    run([*sim, "--no-noise"])
    out = tmp_path / "imm"
    analysed = run(
        ["analyze", "--model", str(model), str(log), "--estimator", "imm", "--out", str(out)],
        expect=2,
    )
    assert analysed.stderr.count("\n") == 1
    assert f"{model}: estimator 'imm' weighs the outputs by their measurement noise" in (
        analysed.stderr
    )
    assert KEY in analysed.stderr
    assert not out.exists()
