"""The error family's helpers (``hybridlog.errors``)."""

import pickle
import re
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from hybridlog.errors import (
    DataShortError,
    DivergenceError,
    HybridlogError,
    LogError,
    ModelError,
    OptionError,
    after_given,
    arithmetic_reason,
    independent_of,
    prefixed,
    printable,
    shortened,
)
from hybridlog.io.mcap_reader import UnfinishedLogError


@pytest.mark.parametrize(
    ("error", "kind"),
    [
        (ModelError("m.toml: noise: singular"), ModelError),
        (DivergenceError("imm diverged at t = 3 s"), DivergenceError),
        (DataShortError("lags: 2 samples"), DataShortError),
        # a subclass elsewhere whose constructor needs more than the message: rebuilding it
        # with the message alone was "unexpected TypeError" in compare
        (
            UnfinishedLogError("a.mcap: no footer", file=Path("a.mcap"), finding="x", readable=3),
            LogError,
        ),
    ],
)
def test_prefixed_keeps_the_kind_and_the_message(error: HybridlogError, kind: type) -> None:
    copy = prefixed(error, "--estimators imm: ")
    assert type(copy) is kind
    assert str(copy) == f"--estimators imm: {error}"


def test_after_given_names_what_the_message_does_not_name_yet() -> None:
    given = {"A": "--set A=0.1", "rho": "--set rho=0.9"}
    named = after_given(DivergenceError("imm diverged at t = 3 s"), given)
    assert type(named) is DivergenceError  # compare still tells a run failure
    assert str(named) == "imm diverged at t = 3 s (after --set A=0.1, --set rho=0.9)"
    assert named.named == {"A", "rho"}
    assert after_given(named, given) is named  # never twice
    own = ModelError("--set A=0.1: m.toml: modes.1.f[0]: not finite", named=["A"])
    assert str(after_given(own, given)).endswith("not finite (after --set rho=0.9)")
    plain = ModelError("m.toml: noise: singular")
    assert after_given(plain, {}) is plain


def test_an_error_independent_of_a_value_does_not_name_it() -> None:
    given = {"A": "--set A=0.1", "smooth": "--smooth"}
    with pytest.raises(DivergenceError) as raised, independent_of(["smooth"]):
        raise DivergenceError("imm cannot explain the log at t = 1 s")
    assert str(after_given(raised.value, given)).endswith("t = 1 s (after --set A=0.1)")


def test_what_an_error_names_survives_a_prefix_and_a_worker() -> None:
    err = OptionError("--set A=0: m.toml: not finite", named=["A"])
    assert prefixed(err, "--estimators imm: ").named == {"A"}
    copy = pickle.loads(pickle.dumps(err))  # a worker's error, sent to the command
    assert type(copy) is OptionError and copy.named == {"A"} and str(copy) == str(err)


def test_an_overflow_of_a_power_is_said_in_words_not_as_an_errno_tuple():
    # unknown-mode on a noisy bioplex log ended its refusal with
    # "(34, 'Numerical result out of range')", the str of Python's ** overflow
    with pytest.raises(OverflowError) as err:
        _ = 10.0**400
    assert arithmetic_reason(err.value) == "Numerical result out of range"
    assert arithmetic_reason(ZeroDivisionError("float division by zero")) == (
        "float division by zero"
    )


def test_a_byte_that_is_not_utf8_reads_alike_in_errors_notes_and_summaries() -> None:
    """Notes and errors wrote it ``\\udcff``, summary.md ``\\xff``: one file, two names."""
    from hybridlog.errors import as_name, excerpt

    name = "runs/r\udcff.csv"
    assert excerpt(name) == "'runs/r\\xff.csv'" == f"'{as_name(name)}'"
    assert excerpt("a\udcffb\n") == "'a\\xffb\\n'"
    assert excerpt("\ud800") == "'\\ud800'"  # a surrogate that is no escaped byte


def test_a_long_line_is_cut_between_words_not_inside_a_number() -> None:
    """``cli_lines.one_line`` cut ``t = 0.0015 s`` into ``t = 0.… s`` (a 405-character
    refusal of ``simulate --disturbance 1e300,1e300``)."""
    text = "a step of the interval from t = 0.0015 s to 0.003 s " + "word " * 80 + "is wrong"
    line = shortened(text, 120)
    assert len(line) <= 120
    assert line.startswith("a step of the interval from t = 0.0015 s to 0.003 s word")
    assert line.endswith(" word is wrong") and " … " in line


@pytest.mark.parametrize(
    "unit", ["e\u0301", "n\u0303\u0301", "\u2764\ufe0f", "\U0001f469\u200d\U0001f467"]
)
@pytest.mark.parametrize("end_share", [1 / 3, 2 / 3])
def test_a_cut_never_parts_a_letter_from_its_combining_marks(unit: str, end_share: float) -> None:
    """A word of accented letters (a path, a quoted cell) cut anywhere: the tail began with
    a combining accent, which sat on the ellipsis ('ééé…\u0301éé'), or half an emoji."""
    for limit in range(20, 60):
        line = shortened(unit * 200, limit, end_share=end_share)
        head, tail = line.split("…")
        assert len(line) <= limit
        assert head == unit * (len(head) // len(unit)), (limit, line)
        assert tail == unit * (len(tail) // len(unit)), (limit, line)


@pytest.mark.parametrize("unit", ["\x1b", "\n", "\u200b", "\U000e0001", "\x00\x07"])
@pytest.mark.parametrize("end_share", [1 / 3, 2 / 3])
def test_a_cut_never_falls_inside_an_escape(unit: str, end_share: float) -> None:
    """The CLI's line escapes control characters, then cuts: a long word of them was cut
    inside an escape, ``\\x1b\\x…0``, a tail that reads as text."""
    whole = re.compile(r"(?:\\x[0-9a-f]{2}|\\u[0-9a-f]{4}|\\U[0-9a-f]{8}|\\n)*")
    for limit in range(20, 60):
        line = shortened(printable(unit * 200), limit, end_share=end_share)
        head, tail = line.split("…")
        assert len(line) <= limit
        assert whole.fullmatch(head) and whole.fullmatch(tail), (limit, line)


@given(
    words=st.lists(st.text("ab1.", min_size=1, max_size=12), min_size=1, max_size=200),
    limit=st.integers(8, 300),
    end_share=st.sampled_from([1 / 3, 1 / 2, 2 / 3]),
)
def test_shortened_keeps_the_ends_and_words_whole_where_it_can(
    words: list[str], limit: int, end_share: float
) -> None:
    text = " ".join(words)
    line = shortened(text, limit, end_share=end_share)
    assert len(line) <= limit
    if len(text) <= limit:
        assert line == text
        return
    head, tail = line.split("…")
    assert text.startswith(head) and text.endswith(tail)
    assert len(line) >= limit * 3 // 4 - 2  # a word boundary is sought near the cut only


def test_an_excerpt_of_a_huge_text_escapes_its_ends_only() -> None:
    """A model file of 50 MB of NUL bytes (one line) took 4 GB to say its line 1 is invalid
    TOML (1.5 GB: killed by the kernel after 2 minutes), a centres file's 40-million-character
    mode name 3 GB: the whole text was escaped a character at a time (a list of 80-byte
    strings) before the excerpt cut it to 60 characters.  The same excerpt now, from the
    ends alone; and printable's only copy is its output."""
    import tracemalloc

    from hybridlog.errors import excerpt, printable

    text = "\x00" * 5_000_000
    tracemalloc.start()
    try:
        shown = excerpt(text, 60)
        excerpt_peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.reset_peak()
        escaped = printable(text)
        printable_peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert shown == "'" + "\\x00" * 10 + "…x00" + "\\x00" * 4 + "'"
    assert escaped == "\\x00" * 5_000_000
    assert excerpt_peak < 4 * len(text)
    assert printable_peak < 2 * len(escaped)


@given(st.text(alphabet="a\x00\né\x85\udcff\udcc3\udca9😀\u200b \U000e0001\ud800", max_size=300))
def test_an_excerpt_cut_before_escaping_is_the_excerpt_of_the_escaped_text(text: str) -> None:
    from hybridlog.errors import as_text, excerpt, printable

    def escaped_first(limit: int) -> str:
        shown = "".join(
            c if c.isprintable() else c.encode("unicode_escape").decode("ascii")
            for c in as_text(text)
        )
        if len(shown) > limit:
            keep = max(limit - 1, 2)
            shown = shown[: keep - keep // 3] + "…" + shown[len(shown) - keep // 3 :]
        return "'" + shown + "'"

    for limit in (1, 2, 3, 4, 10, 60, 80, 120):
        assert excerpt(text, limit) == escaped_first(limit)
    assert printable(text) == escaped_first(10**6)[1:-1]


def test_the_escapes_kept_are_bounded_whatever_the_text() -> None:
    # str.translate's table kept every code point met: a text of all 1.1 million (a
    # notebook quoting hostile names for hours) left them all in the process
    from hybridlog import errors

    beyond = "".join(map(chr, range(0x10000, 0x110000, 3)))  # 348,000 code points
    assert len(errors.printable(beyond)) >= len(beyond)
    assert len(errors._ESCAPES) <= 0x10000
    assert errors.printable("\U0001f600\x00\U000e0001") == "\U0001f600\\x00\\U000e0001"


def test_one_line_joins_lines_and_keeps_the_users_blanks() -> None:
    # all white space was squeezed to one space: 'run  1.csv' was named 'run 1.csv', another
    # file's name, in every error that quoted it
    from hybridlog.errors import excerpt, on_one_line, shortened

    assert shortened(f"no such file {excerpt('run  1.csv')}", 200) == "no such file 'run  1.csv'"
    assert on_one_line("  the model\n    file is bad:\t\n x  ") == "the model file is bad: x"
    assert on_one_line("a\u2028b\r\nc") == "a b c"
