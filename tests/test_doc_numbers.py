"""The numbers README.md and docs/*.md quote from computations are those the code gives (#30).

``data/doc_numbers.csv`` lists them: the file, the text that quotes the number, the number as
printed, the value recorded (SI units, with its relative tolerance) and the group of
``pipelines/record_doc_numbers.py`` that recomputes it. The quoted text must be in its file as
written and show the recorded value rounded as printed, so that a doc edit changing a number
without the table fails, and so does a table edit without the doc. The fast groups (closed forms,
``sacflow validate``'s Hertz numbers, a run of a few seconds) are recomputed here; the slow ones
(the shipped cases at their shipped grids, minutes each, and the groups of more than about ten
seconds, which kept the default suite past its CI budget) with ``pytest -m slow``.
"""

from __future__ import annotations

import importlib.util
import re
from decimal import Decimal
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _recorder():
    spec = importlib.util.spec_from_file_location(
        "record_doc_numbers", ROOT / "pipelines" / "record_doc_numbers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


RECORDER = _recorder()
ROWS = RECORDER.read_table()
FAST = [g for g, (speed, _) in RECORDER.GROUPS.items() if speed == "fast"]
SLOW = [g for g, (speed, _) in RECORDER.GROUPS.items() if speed == "slow"]


def _ids(rows):
    return [f"{r['key']}@{r['file']}" for r in rows]


def test_table_is_well_formed():
    assert list(ROWS[0]) == RECORDER.COLUMNS
    assert len({(r["key"], r["file"], r["quoted"]) for r in ROWS}) == len(ROWS)
    for row in ROWS:
        assert row["group"] in RECORDER.GROUPS, row["key"]
        assert row["speed"] == RECORDER.GROUPS[row["group"]][0], row["key"]
        assert 0.0 < float(row["tolerance"]) < 0.1, row["key"]
        assert row["method"] and row["grid"], row["key"]


@pytest.mark.parametrize("row", ROWS, ids=_ids(ROWS))
def test_quoted_number_is_in_its_doc_and_is_the_recorded_value(row):
    text = (ROOT / row["file"]).read_text(encoding="utf-8")
    assert row["quoted"] in text, f"{row['file']} no longer says {row['quoted']!r}"
    assert row["number"] in row["quoted"]
    # The printed number is the recorded value rounded to the printed digits.
    printed = Decimal(row["number"].replace("−", "-"))
    half_digit = Decimal(1).scaleb(printed.as_tuple().exponent) / 2
    shown = Decimal(repr(float(row["value"]) / float(row["scale"])))
    assert abs(shown - printed) <= half_digit * Decimal("1.0001"), (
        f"{row['key']}: the table records {shown} {row['unit']}, {row['file']} prints {printed}")


def _check(groups, out):
    new = {}
    for group in groups:
        new.update(RECORDER.recompute(group, out))
    rows = [r for r in ROWS if r["key"] in new]
    assert rows
    wrong = {r["key"]: (float(r["value"]), new[r["key"]]) for r in rows
             if not RECORDER.agrees(r, new[r["key"]])}
    assert not wrong, f"recorded vs recomputed: {wrong} (python pipelines/record_doc_numbers.py)"


@pytest.mark.parametrize("group", FAST)
def test_fast_numbers_are_recomputed(group, tmp_path):
    _check([group], tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("group", SLOW)
def test_slow_numbers_are_recomputed(group, tmp_path):
    _check([group], tmp_path)


def test_reference_profile_is_reproduced_byte_for_byte(tmp_path):
    spec = importlib.util.spec_from_file_location(
        "make_hertz_axis", ROOT / "data" / "make_hertz_axis.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    written = module.write(tmp_path)
    assert written.read_bytes() == (ROOT / "data" / written.name).read_bytes()


def test_compare_doc_example_names_shipped_files():
    text = (ROOT / "docs" / "compare.md").read_text(encoding="utf-8")
    for path in re.findall(r"(?:data|configs)/[\w./-]+\.(?:csv|toml|txt|nc)", text):
        assert (ROOT / path).exists(), f"docs/compare.md names {path}, which is not shipped"
