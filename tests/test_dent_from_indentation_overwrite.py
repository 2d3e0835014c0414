"""``pipelines/dent_from_indentation.py --overwrite``: the runner's refusal to replace a run of
another case names ``--overwrite``, so the pipeline must have it, and pass it to its runs only when
asked (a user's runs are kept otherwise)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from sacflow.errors import SacflowError

PIPELINE = Path(__file__).resolve().parents[1] / "pipelines" / "dent_from_indentation.py"


@pytest.fixture
def pipeline():
    spec = importlib.util.spec_from_file_location("dent_from_indentation", PIPELINE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("argv, overwrite", [([], False), (["--overwrite"], True)])
def test_the_press_run_is_replaced_only_when_asked(pipeline, monkeypatch, tmp_path, capsys,
                                                   argv, overwrite):
    asked: list[bool] = []

    def refuse(case, out, **kwargs):
        asked.append(kwargs["overwrite"])
        raise SacflowError(f"{out}/{case.name}.nc holds a run of another case")

    monkeypatch.setattr(pipeline, "run_case", refuse)
    assert pipeline.main(["--out", str(tmp_path), "--no-progress", *argv]) == 2
    assert asked == [overwrite]
    assert "holds a run of another case" in capsys.readouterr().err
