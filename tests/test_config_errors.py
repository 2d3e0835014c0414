"""Every class of bad input gives a short ConfigError naming the field and the fix, and
``sacflow validate`` exits 2 without a traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from sacflow.cli import main
from sacflow.config.parsing import apply_overrides
from sacflow.config.schema import Measured
from sacflow.errors import ConfigError
from sacflow.storage.case_file import load_case

HERTZ = Path(__file__).resolve().parents[1] / "configs" / "hertz-elastic.toml"
TEXT = HERTZ.read_text()

# (id, config text, overrides, words the message must contain)
BAD_INPUTS = [
    ("unknown-key", TEXT, ["grid.nxx=64"], ["grid.nxx", "unknown key", "did you mean 'nx'"]),
    ("unknown-law", TEXT, ['body.hardening.law="swfit"'], ["body.hardening.law", "'swift'"]),
    ("missing-field", TEXT.replace("nz = 16", ""), [], ["grid.nz", "required field missing"]),
    ("wrong-type", TEXT, ['grid.nx="many"'], ["grid.nx", "expected an integer", "'many'"]),
    ("zero-modulus", TEXT, ["body.E=0"], ["body.E", "must be > 0", "Young's modulus"]),
    ("negative-modulus", TEXT, ["body.E=-210e9"], ["body.E", "must be > 0"]),
    ("nu-too-big", TEXT, ["body.nu=0.7"], ["body.nu", "must be in (-1, 0.5)", "got 0.7"]),
    ("nu-too-small", TEXT, ["body.nu=-1.5"], ["body.nu", "must be in (-1, 0.5)"]),
    ("nan-modulus", TEXT, ["body.E=nan"], ["body.E", "finite"]),
    ("negative-load", TEXT, ["load_path.0.to=-1"], ["load_path.0.to", "must be > 0"]),
    ("unload-first", TEXT, ['load_path.0.kind="unload"'], ["load_path.0.kind", '"load"']),
    (
        "load-down",
        TEXT,
        ['load_path.1={kind="load", to=0.1, increments=2}'],
        ["load_path.1.to", "raise the load above 0.65 N"],
    ),
    ("coarse-grid", TEXT, ["grid.nx=8"], ["grid.nx", "cells across", "grid.nx >= 12"]),
    ("coarse-grid-y", TEXT, ["grid.ny=10"], ["grid.ny", "grid.ny >= 12"]),
    ("small-window", TEXT, ["grid.half_width=1.0"], ["grid.half_width", ">= 1.1"]),
    ("small-extent", TEXT, ["grid.extent=[1e-5, 1e-4]"], ["grid.extent", "grid.extent >="]),
    ("rigid-with-modulus", TEXT, ["counterbody.E=1e11"], ["counterbody.E", 'kind = "elastic"']),
    (
        "elastic-without-nu",
        TEXT,
        ['counterbody.kind="elastic"', "counterbody.E=1e11"],
        ["counterbody.nu", "required"],
    ),
    ("two-radii", TEXT, ["counterbody.radii=[1e-4, 1e-4]"], ["counterbody.radius", "exactly one"]),
    ("flat-on-flat", TEXT, ["counterbody.radius=inf"], ["counterbody.radius", "flat"]),
    (
        "swift-unit-missing",
        TEXT,
        ['body.hardening={law="swift", B=1.24e9, C=30, n=0.085}'],
        ["body.hardening.strain_unit", "required field missing"],
    ),
    ("bad-output-field", TEXT, ['output.fields=["presure"]'], ["output.fields.0", "'pressure'"]),
    ("bad-name", TEXT, ['name="Hertz Elastic"'], ["name", "letters, digits"]),
    (
        "missing-surface-file",
        TEXT,
        ['surface={kind="measured", path="nowhere.txt"}'],
        ["surface.path", "nowhere.txt", "file not found"],
    ),
    (
        "toml-syntax",
        TEXT.replace("nx = 128", "nx = = 128"),
        [],
        [
            "TOML syntax error",
            f"line {TEXT.splitlines().index('nx = 128') + 1}",
            "| nx = = 128",
        ],
    ),
    ("bad-override", TEXT, ["grid.nx"], ["--set 'grid.nx'", "key=value"]),
    ("bad-override-index", TEXT, ["load_path.4.to=1"], ["load_path", "index"]),
    ("bad-override-scalar", TEXT, ["grid.nx.n=1"], ["grid.nx is a value"]),
]


def write_config(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "case.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("text", "overrides", "words"), [b[1:] for b in BAD_INPUTS], ids=[b[0] for b in BAD_INPUTS]
)
def test_bad_input_names_field_and_fix(tmp_path, capsys, text, overrides, words):
    path = write_config(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_case(path, overrides)
    message = str(info.value)
    assert message.startswith(str(path)), message
    assert len(message.splitlines()) < 25, message
    for word in words:
        assert word in message, f"{word!r} not in:\n{message}"

    args = ["validate", str(path)] + [f"--set={item}" for item in overrides]
    assert main(args) == 2
    captured = capsys.readouterr()
    assert captured.err.startswith("error: ") and "Traceback" not in captured.err
    assert captured.out == ""


def test_unreadable_surface_file(tmp_path):
    (tmp_path / "surface.txt").write_text("this is not a surface\n")
    path = write_config(tmp_path, TEXT + '\n[surface]\nkind = "measured"\npath = "surface.txt"\n')
    with pytest.raises(ConfigError, match=r"surface\.path: cannot read the measured surface"):
        load_case(path)


def test_relative_surface_path_is_resolved_against_the_config(tmp_path, monkeypatch):
    folder = tmp_path / "cases"
    folder.mkdir()
    rows = "".join(f"{x} {y} 0\n" for x in (-1e-5, 1e-5) for y in (-1e-5, 1e-5))
    (folder / "surface.txt").write_text(rows)
    path = write_config(folder, TEXT + '\n[surface]\nkind = "measured"\npath = "surface.txt"\n')
    monkeypatch.chdir(tmp_path)
    case = load_case(path)
    assert isinstance(case.surface, Measured)
    assert case.surface.path == (folder / "surface.txt").resolve()


def test_unreadable_config_file(tmp_path):
    with pytest.raises(ConfigError, match="cannot read the file"):
        load_case(tmp_path / "missing.toml")
    (tmp_path / "binary.toml").write_bytes(b"\xff\xfe\x00")
    with pytest.raises(ConfigError, match="UTF-8"):
        load_case(tmp_path / "binary.toml")


def test_many_problems_are_cut_short():
    overrides = [f"extra_{i}=1" for i in range(40)]
    with pytest.raises(ConfigError) as info:
        load_case(HERTZ, overrides)
    lines = str(info.value).splitlines()
    assert len(lines) < 25 and lines[-1].strip().startswith("... and")


def test_apply_overrides():
    data = {"grid": {"nx": 8}, "load_path": [{"kind": "load", "to": 1.0}]}
    out = apply_overrides(
        data,
        [
            "grid.nx=64",
            'body.hardening.law="linear"',
            "load_path.0.to=0.19",
            "load_path.1.kind=unload",
            "grid.extent=[1e-5, 2e-5]",
            "body.radii=[inf, 1e-3]",
            "description=two words",
        ],
    )
    assert out["grid"] == {"nx": 64, "extent": [1e-5, 2e-5]}
    assert out["body"] == {"hardening": {"law": "linear"}, "radii": [float("inf"), 1e-3]}
    assert out["load_path"] == [{"kind": "load", "to": 0.19}, {"kind": "unload"}]
    assert out["description"] == "two words"
    assert data["grid"]["nx"] == 8, "the input is not modified"


def test_validate_subprocess_exits_2_without_traceback(tmp_path):
    path = write_config(tmp_path, TEXT)
    result = subprocess.run(
        [sys.executable, "-m", "sacflow.cli", "validate", str(path), "--set", "body.nu=0.7"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert "body.nu: must be in (-1, 0.5)" in result.stderr
