"""Issue #31, part 5: messages that were unclear or silent, each reproduced and made clear."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import xarray as xr

import sacflow
from sacflow.cli import EXIT_BROKEN_PIPE, EXIT_CONFIG, main
from sacflow.compare.output import summary
from sacflow.errors import ConfigError, OutputPathError
from sacflow.storage.case_file import load_case

ROOT = Path(__file__).resolve().parents[1]
HERTZ = ROOT / "configs" / "hertz-elastic.toml"
SMOKE = ROOT / "configs" / "campaign-smoke.toml"


def edited(tmp_path: Path, pattern: str, replacement: str) -> Path:
    path = tmp_path / "case.toml"
    text, count = re.subn(pattern, replacement, HERTZ.read_text(), count=1, flags=re.M)
    assert count == 1
    path.write_text(text)
    return path


def test_a_boolean_for_a_modulus_names_the_modulus(tmp_path):
    with pytest.raises(ConfigError) as caught:
        load_case(edited(tmp_path, r"^E = 210e9.*$", "E = true"))
    message = str(caught.value)
    assert "body.E: expected a number, got true" in message
    assert "counterbody.radius" not in message


@pytest.mark.parametrize(("value", "shown"), [('"16"', "'16'"), ("true", "true")])
def test_text_or_boolean_for_a_cell_count_is_refused(tmp_path, value, shown):
    with pytest.raises(ConfigError, match=f"grid.nx: expected an integer, got (the text )?{shown}"):
        load_case(edited(tmp_path, r"^nx = 128$", f"nx = {value}"))


def test_numbers_stay_accepted_as_before():
    case = load_case(HERTZ, ["grid.nx=16.0", "body.E=210000000000"])  # exact float, int
    assert case.grid.nx == 16 and case.body.E == 210e9
    flat = load_case(ROOT / "configs" / "rolling-smooth.toml")
    assert sacflow.load_case(ROOT / "configs" / "rolling-smooth.toml").case_id == flat.case_id


def test_negative_number_with_exponent_reaches_the_stage(capsys):
    code = main(["compare", "fatigue", "x.nc", "--bending-limit", "-9e8",
                 "--torsion-limit", "3e8"])
    err = capsys.readouterr().err
    assert code == EXIT_CONFIG and "expected one argument" not in err
    assert "-900000000" in err and "> 0" in err


@pytest.mark.parametrize(
    "argv",
    [["material-point", str(HERTZ), "--amplitude", "nan"],
     ["indentation", "x.nc", "--offsets", "0", "nan"],
     ["residual-map", "x.nc", "--depth", "inf"]],
)
def test_nan_and_inf_options_are_refused_at_once(argv, capsys):
    with pytest.raises(SystemExit) as caught:
        main(["compare", *argv])
    assert caught.value.code == EXIT_CONFIG
    assert "expected a finite number" in capsys.readouterr().err


def test_a_campaign_file_given_to_run_and_a_case_to_campaign(tmp_path, capsys):
    assert main(["run", str(SMOKE), "--out", str(tmp_path)]) == EXIT_CONFIG
    err = capsys.readouterr().err
    assert "a campaign file" in err and "sacflow campaign" in err
    assert "required field missing" not in err
    assert main(["campaign", str(HERTZ), "--out", str(tmp_path)]) == EXIT_CONFIG
    err = capsys.readouterr().err
    assert "a case file" in err and "sacflow run" in err and "unknown key" not in err


def test_info_on_a_comparison_output_says_it_is_not_a_run(tmp_path, capsys):
    path = tmp_path / "hertz-hertz-check.nc"
    xr.Dataset({"p0_error": ((), 0.01)}, attrs={"stage": "hertz-check"}).to_netcdf(path)
    stepped = tmp_path / "stepped.nc"
    xr.Dataset({"load": ("step", [0.1])}).to_netcdf(stepped)
    assert main(["info", str(path), str(stepped)]) == 1
    out = capsys.readouterr().out
    assert out.count("a netCDF file, but not a sacflow run") == 2
    assert "id None" not in out and "case: ?" not in out


def test_pipeline_checks_its_overrides_before_the_press(tmp_path):
    out = tmp_path / "dent"
    result = subprocess.run(
        [sys.executable, str(ROOT / "pipelines" / "dent_from_indentation.py"), "--out", str(out),
         "--set", "grid.nx=abc", "--no-progress"],
        capture_output=True, text=True, timeout=120, check=False,
    )
    assert result.returncode == 2 and "grid.nx: expected an integer" in result.stderr
    assert not out.exists(), "nothing was run"


def test_a_stage_verdict_is_printed():
    result = xr.Dataset({"passes": ((), 3.0)},
                        attrs={"stage": "passes", "case": "roll", "verdict": "ratcheting"})
    assert summary(result).splitlines()[1] == "  verdict: ratcheting"


def test_a_closed_pipe_ends_quietly():
    """`sacflow schema | head`: the reader is gone before the writer writes (its end closed)."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        proc = subprocess.run([sys.executable, "-m", "sacflow.cli", "schema"], stdout=write_end,
                              stderr=subprocess.PIPE, timeout=60, check=False)
    finally:
        os.close(write_end)
    err = proc.stderr.decode()
    assert proc.returncode == EXIT_BROKEN_PIPE, err
    assert "Broken pipe" not in err and "Traceback" not in err


def test_python_callers_read_the_parameter_names(tmp_path):
    a_file = tmp_path / "a-file"
    a_file.write_text("")
    with pytest.raises(OutputPathError) as caught:
        sacflow.run(load_case(HERTZ, ["grid.nx=16", "grid.ny=16", "grid.nz=4"]),
                    out_dir=a_file, progress=False)
    message = str(caught.value)
    assert message.startswith(f"out_dir {str(a_file)!r}") and "--out" not in message
    assert 'out_dir="runs"' in message


def test_run_documents_its_keyword_arguments():
    doc = sacflow.run.__doc__ or ""
    for name in ("resume", "overwrite", "simulation_factory", "run_case"):
        assert name in doc
    readme = (ROOT / "README.md").read_text()
    assert "sacflow.run(case, out_dir=" in readme and "overwrite=True" in readme


def test_an_allocation_failure_names_the_resource_and_keeps_the_steps(tmp_path, monkeypatch,
                                                                      capsys):
    import sacflow.runner as runner

    def no_memory(*args, **kwargs):
        raise MemoryError("Unable to allocate 12.0 GiB for an array")

    monkeypatch.setattr(runner, "run_case", no_memory)
    code = main(["run", str(ROOT / "configs" / "hertz-elastic.toml"), "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 1 and "out of memory" in err and "completed steps are kept" in err
    assert "Traceback" not in err
