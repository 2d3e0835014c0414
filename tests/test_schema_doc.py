"""docs/case-format.md is the page ``sacflow schema --markdown`` generates from the models."""

from __future__ import annotations

from pathlib import Path

from sacflow.cli import main
from sacflow.config.schema import Case
from sacflow.config.schema_doc import COMMAND, case_format_markdown

PAGE = Path(__file__).resolve().parents[1] / "docs" / "case-format.md"


def test_committed_page_matches_the_models():
    assert PAGE.is_file(), f"docs/case-format.md is missing; run: {COMMAND}"
    assert PAGE.read_text(encoding="utf-8") == case_format_markdown(), (
        f"docs/case-format.md is out of date with sacflow/config/schema.py; run: {COMMAND}"
    )


def test_page_lists_every_table_key_and_union_variant():
    page = case_format_markdown()
    for key in Case.model_fields:
        assert f"| `{key}` |" in page, key
    for heading in ('`[body.hardening]` with `law = "swift"`',
                    '`[[load_path]]` with `kind = "roll"`',
                    '`[surface]` with `kind = "dented"`', "`[[surface.dents]]`", "`[grid]`"):
        assert heading in page, heading
    assert "| `nx` | int | required | ≥ 8; ≤ 65536 |" in page, "type, default and constraint"
    assert "| `half_width` | float | `1.5` | > 0 |" in page


def test_cli_schema_markdown(capsys):
    assert main(["schema", "--markdown"]) == 0
    assert capsys.readouterr().out == case_format_markdown()
