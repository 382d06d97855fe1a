"""A CSV log that is not UTF-8 is refused naming the line and column of its first bad byte.

Latin-1 (a Windows logger's ``°`` or ``ü``) and UTF-16 (Excel's "Unicode text") were refused
as ``not a readable CSV file (invalid utf-8 sequence)`` or ``not a UTF-8 text file (invalid
start byte)``, which of the two depending on the file's size, and neither said where.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, csv_encoding, inspect_log, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), states=("x",), mode_ids=("1", "2"), dt=0.1)


def _lines(rows: int) -> list[str]:
    return ["t,u,y,note"] + [f"{k / 10},{k},{-k},caf\u00e9" for k in range(rows)]


def _refusals(path: Path) -> list[str]:
    messages = []
    for read in (
        lambda: inspect_log(path),
        lambda: load_signals(path, SPEC, ReadOptions()),
    ):
        with pytest.raises(LogError) as caught:
            read()
        messages.append(str(caught.value))
    return messages


@pytest.mark.parametrize("rows", [5, 5000], ids=["small", "past-the-first-block"])
@pytest.mark.parametrize(
    ("column", "cell"), [("u", "5\u00b0"), ("note", "Z\u00fcndung")], ids=["number", "text"]
)
def test_latin1_cell_is_named_by_line_and_column(
    tmp_path: Path, rows: int, column: str, cell: str
) -> None:
    lines = _lines(rows)
    k = rows - 2
    fields = lines[k + 1].split(",")
    fields[["t", "u", "y", "note"].index(column)] = cell
    lines[k + 1] = ",".join(fields)
    # UTF-8 up to that line (café), Latin-1 from it: the first bad byte is in that cell
    head = "\n".join(lines[: k + 1]) + "\n"
    path = tmp_path / "log.csv"
    path.write_bytes(head.encode() + ("\n".join(lines[k + 1 :]) + "\n").encode("latin-1"))
    byte = f"0x{cell.encode('latin-1')[-6 if column == 'note' else -1]:02x}"
    for message in _refusals(path):
        assert message.startswith(f"{path}, line {k + 2}, column '{column}': byte {byte} ")
        assert "not UTF-8" in message and "iconv" in message and "\n" not in message


def test_latin1_header_names_its_column(tmp_path: Path) -> None:
    path = tmp_path / "log.csv"
    path.write_bytes("t,\u00b5,y\n0,1,2\n".encode("latin-1"))
    for message in _refusals(path):
        assert message.startswith(f"{path}, line 1, column 2 of the header: byte 0xb5 ")


def test_the_line_is_counted_across_blocks(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Read 7 bytes at a time: lines, a two-byte character and the bad byte cross blocks."""
    monkeypatch.setattr(csv_encoding, "READ_AT_ONCE", 7)
    path = tmp_path / "log.csv"
    text = "\n".join(_lines(30)) + "\n"
    path.write_bytes(text.encode() + "30.0,1,2,\u00e9t\u00e9\n".encode("latin-1"))
    with pytest.raises(LogError, match=r"line 32, column 'note': byte 0xe9 "):
        csv_encoding.refuse_not_utf8(path)
    path.write_bytes(text.encode())
    csv_encoding.refuse_not_utf8(path)  # all UTF-8: nothing to say


@pytest.mark.parametrize(
    "encoding", ["utf-16", "utf-16-le", "utf-16-be"], ids=["with-bom", "le-without", "be-without"]
)
def test_utf16_is_named(tmp_path: Path, encoding: str) -> None:
    path = tmp_path / "log.csv"
    path.write_bytes("\n".join(_lines(5)).encode(encoding) + "\n".encode(encoding))
    for message in _refusals(path):
        assert message.startswith(f"{path}: UTF-16 text") and "\n" not in message
        order = encoding[7:].upper()
        assert f"iconv -f UTF-16{order} -t UTF-8" in message


@pytest.mark.parametrize(
    ("data", "where"),
    [
        (b"t,y\r0,1\r1,\xb0\r", "line 1: "),  # classic Mac OS line endings: one line
        (b"t,y\xb0\rz\n0,1\n", "line 1, column 2 of the header: "),  # a stray one after it
        (b"t,y\n0,1\n1\r2,\xb0\n", "line 3: "),  # a stray one before it
    ],
    ids=["mac-line-endings", "in-the-header-after", "in-a-row-before"],
)
def test_a_carriage_return_alone_does_not_stop_the_refusal(
    tmp_path: Path, data: bytes, where: str
) -> None:
    """The csv module refuses a line with a lone CR: it raised in place of naming the byte."""
    path = tmp_path / "log.csv"
    path.write_bytes(data)
    for message in _refusals(path):
        assert message.startswith(f"{path}, {where}byte 0xb0 is not UTF-8")
