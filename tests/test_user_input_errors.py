"""Issue #14: user input never gives a traceback; one material definition.

Each test reproduces a report made on the command line (or through ``load_case``) and checks the
one-screen ``error: ...`` message naming the field, option, environment variable or path and
the fix, with a non-zero exit code -- and, for the hardening laws, that the schema is the one
source of their rules.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sacflow import runner
from sacflow.cli import EXIT_CONFIG, main
from sacflow.config.hardening_laws import hardening_from_schema
from sacflow.config.schema import Case
from sacflow.errors import ConfigError
from sacflow.mechanics.hardening import SwiftHardening, TabularHardening
from sacflow.mechanics.return_mapping import return_map
from sacflow.mechanics.stress_measures import von_mises
from sacflow.storage.case_file import load_case

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
HERTZ = CONFIGS / "hertz-elastic.toml"
INDENT = CONFIGS / "nanoindentation-650mN.toml"
SMOKE = CONFIGS / "campaign-smoke.toml"
TINY = ["--set=grid.nx=16", "--set=grid.ny=16", "--set=grid.nz=4"]
MU = 210e9 / 2.6


def cli(argv: list[str], capsys) -> tuple[int, str]:
    """Exit code and stderr of ``sacflow argv`` run in-process (no traceback may escape)."""
    code = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err


def no_simulation(case):  # pragma: no cover - reached only when the check came too late
    raise AssertionError("the simulation started before the input was checked")


# --------------------------------------------------------------------------- 1. --scheduler
def test_campaign_scheduler_address_is_checked(tmp_path, capsys):
    code, err = cli(["campaign", str(SMOKE), "--scheduler", "not-an-address",
                     "--out", str(tmp_path / "out"), "--no-progress"], capsys)
    assert code == EXIT_CONFIG
    assert err.startswith("error: --scheduler 'not-an-address'") and "tcp://host:8786" in err
    assert not list((tmp_path / "out").glob("*.json")), "no manifest before the check"


@pytest.mark.parametrize("address", ["tcp://host", "host", "tcp://host:0", "tcp://h:70000",
                                     "http://host:8786", "tcp://:8786"])
def test_bad_scheduler_addresses(address):
    from sacflow.campaign import check_scheduler_address

    with pytest.raises(ConfigError, match="--scheduler.*tcp://host:8786"):
        check_scheduler_address(address)


@pytest.mark.parametrize("address", ["tcp://10.0.0.1:8786", "localhost:8786", "tls://[::1]:8786"])
def test_good_scheduler_addresses(address):
    from sacflow.campaign import check_scheduler_address

    check_scheduler_address(address)


# --------------------------------------------------------------------------- 2. --out
def _out_problems(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    file = tmp_path / "a-file"
    file.write_text("not a folder")
    return {
        "existing file": (file, "is an existing file, not a folder"),
        "under a file": (file / "runs", "is a file, so no folder can be created under it"),
    }


@pytest.mark.parametrize("problem", ["existing file", "under a file"])
def test_run_out_is_checked_before_running(tmp_path, capsys, monkeypatch, problem):
    monkeypatch.setattr(runner, "_default_factory", lambda: no_simulation)
    out, what = _out_problems(tmp_path)[problem]
    code, err = cli(["run", str(HERTZ), "--out", str(out), "--no-progress", *TINY], capsys)
    assert code == EXIT_CONFIG
    assert err.startswith(f"error: --out '{out}': ") and what in err and "give a folder path" in err
    assert "Errno" not in err


@pytest.mark.parametrize("problem", ["existing file", "under a file"])
def test_campaign_out_is_checked(tmp_path, capsys, problem):
    out, what = _out_problems(tmp_path)[problem]
    code, err = cli(["campaign", str(SMOKE), "--out", str(out), "--no-progress"], capsys)
    assert code == EXIT_CONFIG and f"--out '{out}': " in err and what in err and "Errno" not in err


def test_compare_out_is_checked_before_comparing(tmp_path, capsys):
    out, what = _out_problems(tmp_path)["existing file"]
    assert main(["run", str(HERTZ), "--out", str(tmp_path), "--no-progress", *TINY]) == 0
    run = tmp_path / "hertz-elastic.nc"
    code, err = cli(["compare", "hertz-check", str(run), "--out", str(out)], capsys)
    assert code == EXIT_CONFIG and f"--out '{out}': {what}" in err and "Errno" not in err


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux /proc")
def test_out_in_a_place_without_folders(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(runner, "_default_factory", lambda: no_simulation)
    code, err = cli(["run", str(HERTZ), "--out", "/proc/x", "--no-progress", *TINY], capsys)
    assert code == EXIT_CONFIG
    assert err.startswith("error: --out '/proc/x': cannot create this folder")
    assert "give a folder path you can write to" in err and "Errno" not in err


def test_campaign_api_out_is_checked(tmp_path):
    from sacflow.campaign import run_campaign

    out, what = _out_problems(tmp_path)["existing file"]
    with pytest.raises(ConfigError, match=what):
        run_campaign(SMOKE, out, progress=False)


# --------------------------------------------------------------------------- 3. list indices
def test_set_index_out_of_range_names_the_valid_indices(capsys):
    code, err = cli(["validate", str(HERTZ), "--set", "load_path.5.to=1"], capsys)
    assert code == EXIT_CONFIG
    assert "index 5 is out of range for load_path" in err
    assert "it has 1 item: use index 0," in err and "0..1" not in err


@pytest.mark.parametrize("index", ["-1", "x", "+0", "²"])
def test_set_negative_or_non_integer_index_rejected(capsys, index):
    code, err = cli(["validate", str(HERTZ), "--set", f"load_path.{index}.to=1"], capsys)
    assert code == EXIT_CONFIG
    assert f"{index!r} is not a list index" in err and "negative indices are not supported" in err


@pytest.mark.parametrize(("key", "message"), [
    ("load_path.-1.to", "'-1' is not a list index"),
    ("load_path.².to", "'²' is not a list index"),
    ("load_path.5.to", "index 5 is out of range for load_path; it has 1 item: use index 0,"),
    ("body.radii.5", "index 5 is out of range for body.radii; it has 2 items: use index 0..1"),
])
def test_sweep_keys_get_the_same_index_checks(tmp_path, capsys, key, message):
    text = SMOKE.read_text().replace('"load_path.0.to" = [0.19, 0.4, 0.65]', f'"{key}" = [1.0]')
    campaign = tmp_path / "campaign.toml"
    campaign.write_text(text)
    code, err = cli(["campaign", str(campaign), "--out", str(tmp_path / "o")], capsys)
    assert code == EXIT_CONFIG and message in err


# --------------------------------------------------------------------------- 4. environment
@pytest.mark.parametrize("value", ["abc", "0", "-1", "1.5"])
def test_bad_fft_threads_variable(tmp_path, capsys, monkeypatch, value):
    monkeypatch.setenv("SACFLOW_FFT_THREADS", value)
    code, err = cli(["run", str(HERTZ), "--out", str(tmp_path), "--no-progress", *TINY], capsys)
    assert code == EXIT_CONFIG
    assert err.startswith(f"error: environment variable SACFLOW_FFT_THREADS={value!r}")
    assert "whole number >= 1" in err


def test_bad_fftw_planner_variable(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SACFLOW_FFTW_PLANNER", "exhaustive")
    code, err = cli(["validate", str(HERTZ)], capsys)
    assert code == EXIT_CONFIG
    assert "SACFLOW_FFTW_PLANNER='exhaustive'" in err and "estimate or measure" in err


def test_fft_threads_variable_read_by_the_operators(monkeypatch):
    from sacflow.kernels.fft import default_threads
    from sacflow.machine import resources

    monkeypatch.setattr(resources, "usable_cores", lambda: 8)
    monkeypatch.setenv("SACFLOW_FFT_THREADS", "3")
    assert default_threads() == 3
    monkeypatch.setenv("SACFLOW_FFT_THREADS", "zero")
    with pytest.raises(ConfigError, match="SACFLOW_FFT_THREADS"):
        default_threads()


# --------------------------------------------------------------------------- 5. text surface
def test_measured_surface_with_a_header_line(tmp_path, capsys):
    surface = tmp_path / "surface.txt"
    points = [f"{x:g} {y:g} 0" for x in (-1e-3, 1e-3) for y in (-1e-3, 1e-3)]
    surface.write_text("\n".join(["# measured", "x1 x2 height", *points]) + "\n")
    case = tmp_path / "case.toml"
    case.write_text(HERTZ.read_text() + '\n[surface]\nkind = "measured"\npath = "surface.txt"\n')
    with pytest.raises(ConfigError) as info:
        load_case(case)
    message = str(info.value)
    assert "surface.path" in message and "line 2: 'x1 x2 height' is not three numbers" in message
    assert "three numeric columns x1 x2 height [m]" in message
    assert "whitespace- or comma-separated" in message and "starting with #" in message
    code, err = cli(["validate", str(case)], capsys)
    assert code == EXIT_CONFIG and "line 2:" in err
    surface.write_text("\n".join(points[:2] + ["1e-3 1e-3"] + points[3:]) + "\n")
    with pytest.raises(ConfigError, match="line 3: '1e-3 1e-3' is not three numbers"):
        load_case(case)
    surface.write_text("\n".join(points) + "\n")  # the same file without the header reads
    assert load_case(case).surface.kind == "measured"


# --------------------------------------------------------------------------- 6. one definition
def test_swift_offset_zero_rejected_by_the_schema(capsys):
    code, err = cli(["validate", str(INDENT), "--set", "body.hardening.C=0"], capsys)
    assert code == EXIT_CONFIG and "body.hardening.C: must be > 0" in err


def test_runtime_laws_use_the_schema_rules():
    with pytest.raises(ValueError, match="hardening law 'swift': field 'C'"):
        SwiftHardening(1240e6, 0.0, 0.085)
    with pytest.raises(ValueError, match="field 'n'"):
        SwiftHardening(1240e6, 30.0, 1.5)  # the old runtime check took any n >= 0
    with pytest.raises(ValueError, match="field 'B'.*initial yield stress"):
        SwiftHardening(1e300, 1e300, 0.99, strain_unit="strain")


# --------------------------------------------------------------------------- 7. tabular end
def test_tabular_beyond_last_point():
    curve = {"law": "tabular", "plastic_strain": (0.0, 1e-3), "stress": (1.0e9, 1.1e9)}
    constant = hardening_from_schema(curve)  # the default, as documented
    extrapolate = hardening_from_schema({**curve, "beyond_last": "extrapolate"})
    assert_allclose(constant.yield_stress(2e-3), 1.1e9, rtol=1e-14)
    assert_allclose(extrapolate.yield_stress(2e-3), 1.2e9, rtol=1e-14)
    assert constant.slope(2e-3) == 0.0 and constant.slope(1e-3) == 0.0
    assert_allclose(extrapolate.slope(2e-3), 1e11, rtol=1e-12)
    # the radial return lands on the surface of the chosen behaviour, past the last point
    trial = np.array([[3.0e9, 0.0, 0.0, 0.0, 0.0, 0.0]])
    for law, expected in ((constant, 1.1e9), (extrapolate, None)):
        res = return_map(trial, 1e-3, law, MU)
        p = 1e-3 + res.equivalent_plastic_strain_increment[0]
        assert p > 1e-3
        target = expected if expected is not None else law.yield_stress(p)
        assert_allclose(von_mises(res.stress)[0], target, rtol=1e-10)
    assert isinstance(constant, TabularHardening) and constant.beyond_last == "constant"


def test_tabular_beyond_last_in_a_case():
    data = load_case(INDENT).model_dump(mode="json")
    data["body"]["hardening"] = {"law": "tabular", "plastic_strain": [0.0, 1e-3],
                                 "stress": [1.0e9, 1.1e9]}
    case = Case.model_validate(data)
    assert case.body.hardening.beyond_last == "constant"
    description = Case.model_json_schema()["$defs"]["Tabular"]["properties"]["beyond_last"]
    assert "constant" in description["description"] and "extrapolate" in description["description"]


def test_no_leftover_output(tmp_path):  # the --out checks create the folder, nothing else
    from sacflow.storage.output_dir import prepare_output_dir

    out = prepare_output_dir(tmp_path / "a" / "b")
    assert out.is_dir() and not list(out.iterdir())
    shutil.rmtree(tmp_path / "a")


def test_a_contact_large_against_its_radius_is_refused():
    # R = 20 µm instead of 20 mm at 4200 N: a = 82 µm, four times R
    path = Path(__file__).resolve().parents[1] / "configs" / "rolling-smooth.toml"
    with pytest.raises(ConfigError, match=r"counterbody\.radius: .*4\.09 times the effective "
                                          r"radius.*a/R <= 0\.5"):
        load_case(path, ["counterbody.radius=20e-6"])


@pytest.mark.parametrize("override", ["load_path.1.distance=1e300", "load_path.0.at=[1e300, 0]"])
def test_a_track_longer_than_the_body_grid_can_hold_is_refused(override):
    path = Path(__file__).resolve().parents[1] / "configs" / "dent-rolling.toml"
    with pytest.raises(ConfigError, match=r"load_path\.[01]\.(distance|at): the load travels "
                                          r"1e\+300 m .*at most 65536 cells"):
        load_case(path, [override])
