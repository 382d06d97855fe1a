"""The loaded-model cache: a warm run gets the same model without sympy, never a stale one.

A model read from ``<cache>/loaded`` must equal the one the loader builds, bit for bit in
every number and exactly in every expression (built again from the text when first read);
any change of text, parameters, code or library versions must give another file; a damaged
or foreign file is ignored and rewritten; errors name the file and key as the loader does.
"""

import dataclasses
import os
import pickle
import subprocess
import sys
import textwrap
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import sympy

import hybridlog
from hybridlog.errors import ModelError
from hybridlog.estimators.capabilities import ModelTraits
from hybridlog.model import cache
from hybridlog.model.compiled import model_key
from hybridlog.model.hybrid_model import Deferred, HybridModel, stored
from hybridlog.model.loader import load_model, parse_model
from tests.support.model_kinds import (
    CLUTCH_JUMPS,
    CONTINUOUS_TANK,
    THREE_COMPONENTS,
    VALVES_BOOLEAN,
)
from tests.support.models import LINEAR_TWO_MODE, PENDULUM_ONE_MODE

TEXTS = {
    "linear_two_mode": LINEAR_TWO_MODE,
    "pendulum": PENDULUM_ONE_MODE,
    "continuous_tank": CONTINUOUS_TANK,
    "valves_boolean": VALVES_BOOLEAN,
    "clutch_jumps": CLUTCH_JUMPS,
}
BUILTINS = ("three_tank_hstf", "double_cart_case1", "double_cart_case2", "ice_clutch")


@pytest.fixture(autouse=True)
def cache_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("HYBRIDLOG_CACHE_DIR", str(folder))
    return folder


def cached_files(folder: Path) -> list[Path]:
    return sorted((folder / "loaded").glob("model_*.json"))


def assert_same(warm: Any, cold: Any, where: str = "model") -> None:
    """Equal in every field: arrays bit for bit (dtype, shape, bytes), expressions exactly."""
    if isinstance(cold, np.ndarray):
        assert isinstance(warm, np.ndarray), where
        assert (warm.dtype, warm.shape) == (cold.dtype, cold.shape), where
        assert warm.tobytes() == cold.tobytes(), where
    elif dataclasses.is_dataclass(cold) and not isinstance(cold, type):
        assert type(warm) is type(cold), where
        for item in dataclasses.fields(cold):
            name = f"{where}.{item.name}"
            assert_same(getattr(warm, item.name), getattr(cold, item.name), name)
    elif isinstance(cold, Mapping):
        assert isinstance(warm, Mapping) and list(warm) == list(cold), where
        for name in cold:
            assert_same(warm[name], cold[name], f"{where}[{name!r}]")
    elif isinstance(cold, tuple | list):
        assert type(warm) is type(cold) and len(warm) == len(cold), where
        for index, (a, b) in enumerate(zip(warm, cold, strict=True)):
            assert_same(a, b, f"{where}[{index}]")
    else:
        assert type(warm) is type(cold), where
        assert warm == cold, where


def write_model(folder: Path, name: str, text: str) -> Path:
    path = folder / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("name", [*BUILTINS, *TEXTS])
def test_a_cached_model_equals_the_built_one(name: str, tmp_path: Path, cache_folder: Path):
    reference = name if name in BUILTINS else write_model(tmp_path, name, TEXTS[name])
    cold = load_model(reference)
    assert len(cached_files(cache_folder)) == 1
    warm = load_model(reference)
    # The warm model came from the file: its expressions are not built yet.
    assert isinstance(stored(warm.modes[0], "h"), Deferred)
    assert model_key(warm) == model_key(cold)
    assert_same(warm, cold)
    # Built again from the text, its key is the stored one.
    assert model_key(dataclasses.replace(warm, name=warm.name)) == model_key(cold)


def test_with_parameters_each_set_has_its_own_model(tmp_path: Path, cache_folder: Path):
    path = write_model(tmp_path, "pendulum", PENDULUM_ONE_MODE)
    plain = load_model(path)
    name = next(iter(plain.parameters))
    changed = load_model(path, parameters={name: plain.parameters[name] + 1.0})
    assert changed.parameters[name] == plain.parameters[name] + 1.0
    assert load_model(path).parameters == plain.parameters
    again = load_model(path, parameters={name: plain.parameters[name] + 1.0})
    assert isinstance(stored(again.modes[0], "f"), Deferred)
    assert_same(again, changed)
    assert len(cached_files(cache_folder)) == 2


def test_every_change_of_what_shapes_the_model_gives_a_new_key(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    text = LINEAR_TWO_MODE
    key = cache.loaded_key(text, {})
    assert cache.loaded_key(text, {}) == key
    assert cache.loaded_key(text + " ", {}) != key
    assert cache.loaded_key(text, {"a": 1.0}) != key
    assert cache.loaded_key(text, {"a": 1.0}) != cache.loaded_key(text, {"a": 2.0})
    assert cache.loaded_key(text, {"a": 1}) != cache.loaded_key(text, {"a": 1.0})

    def changed(**patches: Any) -> str:
        with monkeypatch.context() as patch:
            for target, value in patches.items():
                patch.setattr(target.replace(":", "."), value)
            cache._code_fingerprint.cache_clear()
            try:
                return cache.loaded_key(text, {})
            finally:
                cache._code_fingerprint.cache_clear()

    assert changed(**{"hybridlog:__version__": "99.0"}) != key

    def another_sympy() -> str:
        return '__version__ = "0.0"\n'

    assert changed(**{"hybridlog.model.cache:sympy_release": another_sympy}) != key
    # An edit of any module of hybridlog.model (the loader, the grammar, the types ...).
    copies = tmp_path / "model"
    copies.mkdir()
    for source in Path(cache.__file__).parent.glob("*.py"):
        copies.joinpath(source.name).write_bytes(source.read_bytes())
    assert changed(**{"hybridlog.model.cache:__file__": str(copies / "cache.py")}) == key
    loader = copies / "loader.py"
    loader.write_text(loader.read_text(encoding="utf-8") + "\n# edited\n", encoding="utf-8")
    assert changed(**{"hybridlog.model.cache:__file__": str(copies / "cache.py")}) != key
    assert cache.loaded_key(text, {}) == key


def damage_truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def damage_garble(path: Path) -> None:
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle] = ord("7") if data[middle] != ord("7") else ord("8")
    path.write_bytes(bytes(data))


def damage_binary(path: Path) -> None:
    path.write_bytes(b"\x00\xff\xfe garbage \x80")


def damage_empty(path: Path) -> None:
    path.write_bytes(b"")


def damage_foreign_body(path: Path) -> None:
    # A well-framed file for this key whose body is not a model.
    key = path.stem.removeprefix("model_")
    path.write_text(cache.framed_module(cache.KIND, key, '{"modes": 3}'), encoding="utf-8")


def damage_another_model(path: Path) -> None:
    # Another model's intact file under this name: its header names another key.
    other = cache.cached_model(PENDULUM_ONE_MODE, origin="other.toml")
    assert other.name
    others = [p for p in path.parent.glob("model_*.json") if p != path]
    path.write_bytes(others[0].read_bytes())


@pytest.mark.parametrize(
    "damage",
    [
        damage_truncate,
        damage_garble,
        damage_binary,
        damage_empty,
        damage_foreign_body,
        damage_another_model,
    ],
)
def test_a_damaged_or_foreign_cache_file_is_ignored_and_rewritten(
    damage: Any, tmp_path: Path, cache_folder: Path
):
    path = write_model(tmp_path, "linear", LINEAR_TWO_MODE)
    cold = load_model(path)
    (stored_file,) = cached_files(cache_folder)
    intact = stored_file.read_bytes()
    damage(stored_file)
    rebuilt = load_model(path)
    assert not isinstance(stored(rebuilt.modes[0], "h"), Deferred)  # built, not read
    assert_same(rebuilt, cold)
    assert stored_file.read_bytes() == intact
    assert isinstance(stored(load_model(path).modes[0], "h"), Deferred)


def test_a_model_that_cannot_be_stored_exactly_is_built_every_time(
    tmp_path: Path, cache_folder: Path
):
    components = write_model(tmp_path, "components", THREE_COMPONENTS)
    assert load_model(components).components
    dated = LINEAR_TWO_MODE + "\n[estimators.imm]\nwhen = 2026-11-29\n"
    path = write_model(tmp_path, "dated", dated)
    model = load_model(path)
    assert str(model.estimator_options["imm"]["when"]) == "2026-11-29"
    assert cached_files(cache_folder) == []
    assert load_model(path).estimator_options == model.estimator_options


def test_errors_name_the_file_and_key_the_same_cold_and_warm(tmp_path: Path):
    path = write_model(tmp_path, "pendulum", PENDULUM_ONE_MODE)
    cold = load_model(path)
    warm = load_model(path)
    assert isinstance(stored(warm.modes[0], "f"), Deferred)
    with pytest.raises(ModelError) as cold_error:
        cold.linear_modes()
    with pytest.raises(ModelError) as warm_error:
        warm.linear_modes()
    assert str(warm_error.value) == str(cold_error.value)
    assert str(warm_error.value).startswith(f"{path}: modes.")
    assert ModelTraits(warm).nonlinear == ModelTraits(cold).nonlinear
    # The same text under another name: errors name the file the user gave now.
    other = write_model(tmp_path, "other", PENDULUM_ONE_MODE)
    moved = load_model(other)
    assert isinstance(stored(moved.modes[0], "f"), Deferred)
    assert moved.origin == str(other)
    with pytest.raises(ModelError, match=f"^{other}: modes"):
        moved.linear_modes()
    # An invalid model is never cached: the same error every time.
    broken = write_model(tmp_path, "broken", LINEAR_TWO_MODE.replace("[modes.", "[mode.", 1))
    messages = set()
    for _ in range(2):
        with pytest.raises(ModelError) as error:
            load_model(broken)
        messages.add(str(error.value))
    assert len(messages) == 1 and messages.pop().startswith(f"{broken}: ")


def test_a_warm_model_built_again_must_match_its_file(tmp_path: Path, cache_folder: Path):
    path = write_model(tmp_path, "linear", LINEAR_TWO_MODE)
    load_model(path)
    (stored_file,) = cached_files(cache_folder)
    key = stored_file.stem.removeprefix("model_")
    body = stored_file.read_text(encoding="utf-8").split("\n", 1)[1].rpartition("\n# end ")[0]
    body = body.replace('"name": "', '"name": "forged ', 1)
    stored_file.write_text(cache.framed_module(cache.KIND, key, body), encoding="utf-8")
    forged = load_model(path)
    assert forged.name.startswith("forged")
    with pytest.raises(ModelError, match="does not match the model file"):
        _ = forged.modes[0].f


def test_the_deferred_expressions_are_the_loaders(tmp_path: Path):
    path = write_model(tmp_path, "clutch", CLUTCH_JUMPS)
    load_model(path)
    warm = load_model(path)
    cold = parse_model(CLUTCH_JUMPS, origin=str(path))
    for warm_jump, cold_jump in zip(warm.jumps, cold.jumps, strict=True):
        assert isinstance(stored(warm_jump, "reset"), Deferred)
        assert warm_jump.reset == cold_jump.reset
        assert all(isinstance(e, sympy.Basic) for e in warm_jump.reset)
    assert isinstance(warm, HybridModel)


@pytest.mark.parametrize("name", ["double_cart_case1", "double_cart_case2", "linear_two_mode"])
def test_the_observers_linear_modes_are_the_loaders_bit_for_bit(name: str, tmp_path: Path):
    # chiu and kmeans take the matrices the loader worked out (no sympy on a warm run);
    # they must be the Jacobians the observer computed from the expressions before.
    from hybridlog.estimators.switched_observer import linear_modes

    reference = name if name in BUILTINS else write_model(tmp_path, name, TEXTS[name])
    load_model(reference)
    warm = load_model(reference)
    assert all(mode.linear_form is not None for mode in warm.modes)
    from_forms = linear_modes(warm)
    assert isinstance(stored(warm.modes[0], "f"), Deferred)  # no expression was built
    symbolic = dataclasses.replace(
        warm, modes=tuple(dataclasses.replace(m, linear_form=None) for m in warm.modes)
    )
    assert_same(from_forms, linear_modes(symbolic))


def test_a_warm_model_can_be_sent_to_another_process(tmp_path: Path):
    path = write_model(tmp_path, "pendulum", PENDULUM_ONE_MODE)
    cold = load_model(path)
    warm = load_model(path)
    assert isinstance(stored(warm.modes[0], "f"), Deferred)
    assert_same(pickle.loads(pickle.dumps(warm)), cold)
    _ = warm.modes[0].f  # built here: the copy still carries only the text
    assert_same(pickle.loads(pickle.dumps(warm)), cold)


def test_a_model_sent_to_another_process_carries_its_key(tmp_path: Path):
    """The content key of a warm model, which the loaded-model cache stores, travels with it
    pickled: the receiving process (the estimators' worker) loads the model's compiled code
    without parsing an equation.  A model whose key was never known sends none."""
    path = write_model(tmp_path, "pendulum", PENDULUM_ONE_MODE)
    load_model(path)
    warm = load_model(path)
    code = textwrap.dedent(
        """
        import pickle, sys
        from hybridlog.model.keys import known_key
        model = pickle.loads(sys.stdin.buffer.read())
        print(known_key(model), "sympy" in sys.modules)
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        input=pickle.dumps(warm),
        capture_output=True,
        check=True,
    )
    assert done.stdout.decode().split() == [model_key(warm), "False"]
    assert parse_model(PENDULUM_ONE_MODE).__getstate__()["__content_key__"] is None


def test_a_warm_analyze_and_simulate_import_no_sympy(tmp_path: Path):
    """Issue 8, must-hold 2: a warm run imports no sympy, loader or code generator.

    The filters (hstf) and the observers (kmeans, the path of chiu too) and ``simulate``.
    """
    code = textwrap.dedent(
        """
        import sys
        from hybridlog.cli import main
        from hybridlog.jobs.simulate import simulate_log

        for log, model, estimator in (("three_tank_hstf", "three_tank_hstf", "hstf"),
                                      ("double_cart_case1", "double_cart_case1", "kmeans")):
            try:
                main(["analyze", f"sample_logs/{log}.csv", "--model", model, "--estimator",
                      estimator, "--out", f"{sys.argv[1]}_{estimator}", "--force", "-q"])
            except SystemExit as done:
                assert done.code in (0, None), done.code
        simulate_log("double_cart_case1", sys.argv[2], steps=30, seed=1, force=True)
        heavy = ("sympy", "mpmath", "hybridlog.model.loader", "hybridlog.model.codegen",
                 "hybridlog.model.expressions", "hybridlog.model.derivatives")
        print(",".join(name for name in heavy if name in sys.modules))
        """
    )
    root = Path(hybridlog.__file__).parent.parent
    environment = {**os.environ}
    environment.pop("HYBRIDLOG_CACHE_DIR", None)  # the user's cache, warm after a first run
    arguments = [sys.executable, "-c", code, str(tmp_path / "out"), str(tmp_path / "sim.csv")]
    for _ in range(2):  # the first run warms the cache when no earlier run did
        done = subprocess.run(
            arguments, cwd=root, env=environment, capture_output=True, text=True, check=True
        )
    assert done.stdout.strip() == ""


def test_the_sympy_release_in_the_keys_is_the_installed_one_read_without_sympy() -> None:
    """``keys.sympy_release`` names the installed sympy (as its distribution's metadata
    does) and imports neither sympy nor ``importlib.metadata`` (a fresh process)."""
    import importlib.metadata

    from hybridlog.model.keys import sympy_release

    assert f'"{importlib.metadata.version("sympy")}"' in sympy_release()
    probe = (
        "import sys; from hybridlog.model.keys import sympy_release; sympy_release(); "
        "print(sorted(m for m in ('sympy', 'importlib.metadata') if m in sys.modules))"
    )
    shown = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert shown.returncode == 0, shown.stderr
    assert shown.stdout.strip() == "[]"


def test_a_warm_model_says_whether_its_outputs_differ_by_mode_without_sympy(
    cache_folder: Path,
) -> None:
    """hstf's note (and the step-into warning) asks whether the modes' ``h`` differ: on a
    warm nonlinear model that parsed every ``h`` with sympy, 0.4 s of each warm hstf run.
    The loader's answer is kept in the cache; a model without modes says no (it raised)."""
    cold = load_model("three_tank_hstf")
    warm = load_model("three_tank_hstf")
    assert cold.outputs_differ is True and warm.outputs_differ is True
    assert isinstance(stored(warm.modes[0], "h"), Deferred)
    assert warm.outputs_differ_by_mode and isinstance(stored(warm.modes[0], "h"), Deferred)
    assert load_model("double_cart_case1").outputs_differ_by_mode is False
    assert load_model("bioplex_pgc").outputs_differ_by_mode is False


def test_replaced_leaves_an_inherited_symbolic_field_unread() -> None:
    """``replaced`` found a :class:`Symbolic` field by the class's own ``__dict__``: on a
    dataclass that extends one holding the field, it read (computed) the field as
    ``dataclasses.replace`` does."""
    from dataclasses import dataclass

    from hybridlog.model.hybrid_model import Symbolic, replaced

    @dataclass(frozen=True)
    class Base:
        a: int
        e: Symbolic[int] = Symbolic(0)  # noqa: RUF009 (a descriptor, as HybridModel's)

    @dataclass(frozen=True)
    class Extended(Base):
        b: int = 1

    computed: list[int] = []
    held = Extended(1, Deferred(lambda: computed.append(1) or 5), 2)  # type: ignore[arg-type]
    copy = replaced(held, b=3)
    assert not computed
    assert isinstance(stored(copy, "e"), Deferred)
    assert (copy.a, copy.b, copy.e) == (1, 3, 5)


@pytest.mark.parametrize(
    ("name", "parameters", "shown"),
    [
        (None, None, "model: expected a built-in name .* got the NoneType 'None'"),
        (3, None, "model: .* got the int '3'"),
        ("", None, "model: .* got the str ''"),
        (
            "three_tank_hstf",
            ["A=140"],
            r"three_tank_hstf: parameters: .* got the list '\['A=140'\]'",
        ),
        ("three_tank_hstf", {1: 2.0}, "three_tank_hstf: parameters: .* got the dict"),
    ],
)
def test_an_argument_of_the_wrong_type_is_a_model_error(name, parameters, shown):
    # a TypeError, ValueError or AttributeError of Python's escaped from the library call
    with pytest.raises(ModelError, match=shown):
        load_model(name, parameters=parameters)
