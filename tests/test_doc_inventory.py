"""Every number README.md and docs/*.md quote is accounted for (#30): computed, or declared not.

A *number token* of a doc is, outside fenced code blocks, inline code, links' targets and
references to equations, sections, figures and DOIs (``eq. 3.45``, ``§1.7``, ``Fig. 22``,
``doi:...``, which name things rather than quote values):

* a number with a fractional part or an exponent (``0.487``, ``2.1e-5``, ``1e-8``): results and
  parameters alike, dimensionless ones included (Dang Van indices, orders, ratios, εp);
* a whole number followed by a unit (``UNITS``: stress, length, %, p0, k, a, N, time, memory,
  ``cells``, ``cases``, ``iterations``, ``×`` written against it as in ``3×``), directly or
  through a list or range of numbers sharing that unit (``21–25 s``, ``2, 3 and 5 cells``,
  ``{10, 20, 35} µm``): every number of the list is a token;
* a whole number that is a markdown table cell by itself (``| 327 |``, ``| -7 |``, ``| +70 |``).

Each token must lie inside the ``quoted`` text of a row of ``data/doc_numbers.csv`` for that
file, as that row's ``number`` (computed: a group of ``pipelines/record_doc_numbers.py``
recomputes it, ``tests/test_doc_numbers.py`` checks it), or as one of the ``numbers`` of a row
of ``data/doc_inputs.csv`` (not computed: an input of a case or campaign, a literature value
with its reference, a definition or convention, a machine measurement with the benchmark that
prints it). The failure message lists the uncovered tokens with their line: the work list.

``docs/performance.md`` is exempt as a whole: it is a dated log of machine measurements (wall
times, memory) of ``benchmarks/*.py``, which change with the machine and cannot be recomputed
to their digits; every figure there is a ``measurement`` by construction, and the test checks
that the page says so.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
INPUTS = ROOT / "data" / "doc_inputs.csv"
NUMBERS = ROOT / "data" / "doc_numbers.csv"

#: Every doc the inventory covers: README.md and each page of docs/.
FILES = ["README.md", "docs/architecture.md", "docs/campaigns.md", "docs/case-format.md",
         "docs/compare.md", "docs/convergence.md", "docs/dent-study.md", "docs/fatigue.md",
         "docs/friction.md", "docs/inclusions.md", "docs/initial-states.md",
         "docs/performance.md", "docs/repeated-rolling.md"]
#: Exempt as a whole, with the sentence each must contain to say why.
EXEMPT = {"docs/performance.md": "python benchmarks/<name>.py"}
#: What a row of data/doc_inputs.csv may be: an input of a shipped case, campaign or example; a
#: value from the literature (the reference in ``source``); a definition or convention (a default,
#: a threshold, a unit); a machine measurement (the script that prints it in ``source``); a bound
#: a test asserts (``below 1 %``: the test in ``source``).
KINDS = {"input", "literature", "definition", "measurement", "bound"}
INPUT_COLUMNS = ["key", "file", "quoted", "numbers", "kind", "source"]

UNITS = ("GPa", "MPa", "kPa", "Pa", "µm", "μm", "nm", "mm", "m", "%", "p0", "k", "a", "N",
         "mN", "σY", "s", "ms", "min", "GB", "MB", "MiB", "GiB", "cells", "cases",
         "iterations")
_NUMBER = r"\d+(?:\.\d+)?(?:e[−-]?\d+)?"
#: A number: not part of a name (x1, p0, float32), a path or a power (2^-24, 1/8).
NUMBER = re.compile(rf"(?<![\w.^/\\]){_NUMBER}(?![\w.]*\d)")
_UNIT = "|".join(sorted((re.escape(u) for u in UNITS), key=len, reverse=True))
#: A number or a list/range of numbers, then a unit (or ``×`` written against the number).
WITH_UNIT = re.compile(
    rf"(?<![\w.^/\\])[−+-]?{_NUMBER}"
    rf"(?:\s*(?:,|–|-|…|to|and)\s*[−+-]?{_NUMBER})*[)}}\]]?(?:\s?(?:{_UNIT})(?![\w])|×)")
CELL = re.compile(rf"(?<=\|)\s*[−+±-]?({_NUMBER})\s*(?=\|)")
#: Text that is not prose: fenced blocks, inline code, link targets, named references.
NOT_PROSE = [re.compile(r"^```.*?^```", re.S | re.M), re.compile(r"`[^`\n]*`"),
             re.compile(r"\]\([^)]*\)"), re.compile(r"https?://\S+"),
             re.compile(r"doi:\S+"),
             re.compile(rf"(?:\beqs?\.|§|\bFigs?\.|\bTables?)\s*{_NUMBER}"
                        rf"(?:\s*(?:–|-|,|and)\s*{_NUMBER})*")]


def _blank(text: str) -> str:
    """The text with what is not prose replaced by spaces (positions kept)."""
    for pattern in NOT_PROSE:
        text = pattern.sub(lambda m: re.sub(r"[^\n]", " ", m.group()), text)
    return text


def tokens(text: str) -> dict[int, str]:
    """The number tokens of a doc: {offset of the first digit: the number as printed}."""
    prose = _blank(text)
    found: dict[int, str] = {}
    for match in NUMBER.finditer(prose):
        if re.search(r"[.e]", match.group()):
            found[match.start()] = match.group()
    for match in WITH_UNIT.finditer(prose):
        for number in NUMBER.finditer(match.group()):
            found[match.start() + number.start()] = number.group()
    for line in re.finditer(r"^\|.*$", prose, re.M):
        for cell in CELL.finditer(line.group()):
            found[line.start() + cell.start(1)] = cell.group(1)
    return found


def _occurrences(text: str, quoted: str) -> list[int]:
    return [m.start() for m in re.finditer(re.escape(quoted), text)]


def covered(text: str, quoted: str, number: str) -> set[int]:
    """Offsets (first digit) of ``number`` inside every occurrence of ``quoted`` in the text."""
    digits = number.lstrip("−+-±")
    inside = [m.start() for m in re.finditer(rf"(?<![\d.]){re.escape(digits)}(?![\d])(?!\.\d)",
                                             quoted)]
    return {start + offset for start in _occurrences(text, quoted) for offset in inside}


def _read(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


INPUT_ROWS = _read(INPUTS)
NUMBER_ROWS = _read(NUMBERS)


def uncovered(name: str) -> list[str]:
    """The tokens of a doc no row covers, as ``line N: number in <the line>``."""
    text = (ROOT / name).read_text(encoding="utf-8")
    done: set[int] = set()
    for row in NUMBER_ROWS:
        if row["file"] == name:
            done |= covered(text, row["quoted"], row["number"])
    for row in INPUT_ROWS:
        if row["file"] == name:
            for number in row["numbers"].split():
                done |= covered(text, row["quoted"], number)
    missing = []
    for offset, number in sorted(tokens(text).items()):
        if offset not in done:
            line = text.count("\n", 0, offset) + 1
            missing.append(f"line {line}: {number} in {text.splitlines()[line - 1].strip()!r}")
    return missing


def test_files_are_every_doc():
    docs = {"README.md"} | {f"docs/{p.name}" for p in (ROOT / "docs").glob("*.md")}
    assert set(FILES) == docs
    assert set(EXEMPT) <= set(FILES)


@pytest.mark.parametrize("name", FILES)
def test_every_number_token_is_computed_or_declared(name):
    if name in EXEMPT:
        text = (ROOT / name).read_text(encoding="utf-8")
        assert EXEMPT[name] in text and "measured" in text, (
            f"{name} is exempt as a log of benchmark measurements and must say so")
        return
    missing = uncovered(name)
    assert not missing, (f"{len(missing)} number(s) of {name} in no row of data/doc_numbers.csv "
                         "or data/doc_inputs.csv:\n" + "\n".join(missing))


def test_input_table_is_well_formed():
    assert INPUT_ROWS and list(INPUT_ROWS[0]) == INPUT_COLUMNS
    assert len({r["key"] for r in INPUT_ROWS}) == len(INPUT_ROWS)
    for row in INPUT_ROWS:
        assert row["kind"] in KINDS, f"{row['key']}: kind {row['kind']!r} not in {KINDS}"
        assert row["source"], f"{row['key']}: say where the number comes from"
        assert row["file"] in FILES and row["file"] not in EXEMPT, row["key"]
        assert row["numbers"].split(), f"{row['key']}: no number"


@pytest.mark.parametrize("row", INPUT_ROWS, ids=[r["key"] for r in INPUT_ROWS])
def test_input_rows_quote_their_doc(row):
    text = (ROOT / row["file"]).read_text(encoding="utf-8")
    assert row["quoted"] in text, f"{row['file']} no longer says {row['quoted']!r} (stale row)"
    for number in row["numbers"].split():
        assert covered(text, row["quoted"], number), f"{row['key']}: {number} not quoted"


#: Where the script behind a measurement (or the ``sacflow`` command that prints it), or the
#: test behind a bound, must be.
SCRIPT_FOLDERS = {"measurement": "(?:benchmarks|pipelines)", "bound": "tests"}


def test_measurements_and_bounds_name_their_script():
    for row in INPUT_ROWS:
        if row["kind"] in SCRIPT_FOLDERS:
            scripts = re.findall(rf"{SCRIPT_FOLDERS[row['kind']]}/[\w-]+\.py", row["source"])
            command = row["kind"] == "measurement" and re.search(
                r"\bsacflow (?:run|campaign) (?:configs|pipelines)/[\w-]+\.toml", row["source"])
            assert scripts or command, f"{row['key']}: name the script that prints it"
            assert all((ROOT / s).exists() for s in scripts), row["key"]


def test_the_scanner_finds_what_it_should():
    text = ("| 10 | 0.022 | -7 |\nσ11 of 1.5 GPa at x1 = 2 µm, 21–25 s, 3× faster, 2, 3 and 5 "
            "cells, p0 = 6 k; eq. 3.45, §1.7, `--set nx=64`, float32, 1/8, 2^-24 ≈ 6e-8")
    assert sorted(tokens(text).values()) == sorted(
        ["10", "0.022", "7", "1.5", "2", "21", "25", "3", "2", "3", "5", "6", "6e-8"])
