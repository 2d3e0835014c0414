"""The README's Python snippets run as written, against tiny real runs.

Every ```python block of README.md is executed in the repository root with ``runs/`` pointing
to a temporary folder; ``sacflow.load_case`` returns the case at a tiny grid (16 × 16 cells, 4
layers, one increment per segment) so that the snippet's own runs take a few seconds. The
``hertz-elastic`` run the snippet opens is made first, at the same tiny grid.
"""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib
import pytest
from test_configs import tiny_case

import sacflow
import sacflow.storage.case_file
from sacflow.runner import run_case

matplotlib.use("Agg")  # the snippets plot; no display in the tests

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
#: A fenced Python block of the README.
PYTHON_BLOCK = re.compile(r"^```python\n(.*?)^```", re.MULTILINE | re.DOTALL)
#: Tiny grid of the snippet runs: the fewest cells the case checks allow at half_width 2.
TINY_CELLS, TINY_LAYERS = 16, 4


def python_blocks(text: str) -> list[str]:
    """The bodies of the ```python fenced blocks of a Markdown text, in order."""
    return PYTHON_BLOCK.findall(text)


def tiny(case):
    """``case`` at a tiny grid, with one increment per load segment and three roll steps."""
    return tiny_case(case, TINY_CELLS, TINY_LAYERS)


def test_readme_has_python_snippets():
    assert python_blocks(README.read_text(encoding="utf-8")), "no ```python block in README.md"


@pytest.mark.parametrize("index", range(len(python_blocks(README.read_text(encoding="utf-8")))))
def test_readme_python_snippet_runs(index, tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    code = python_blocks(README.read_text(encoding="utf-8"))[index]
    load_case = sacflow.storage.case_file.load_case

    def tiny_load_case(path, overrides=()):
        return tiny(load_case(path, overrides))

    run_case(tiny(load_case(ROOT / "configs" / "hertz-elastic.toml")), tmp_path / "runs",
             progress=False)
    monkeypatch.setattr(sacflow.storage.case_file, "load_case", tiny_load_case)
    monkeypatch.chdir(ROOT)  # the snippets name configs/ relative to the repository
    code = code.replace('"runs/', f'"{tmp_path / "runs"}/')
    try:
        exec(compile(code, f"README.md python block {index}", "exec"), {"__name__": "readme"})
    finally:
        plt.close("all")
