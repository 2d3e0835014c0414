"""Output size options: volume fields in float32, and volume fields stored at every step.

The solver runs in float64 either way: a float32 file holds the float64 results rounded once
(relative error at most 2^-24 = 6e-8 of each value), its parts and restart state stay float64
so that an interrupted run resumes exactly, and a case that does not ask keeps its case id.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_resume import INDENT, TINY_INDENT, assert_same_run, interrupt

import sacflow
from sacflow import runner
from sacflow.errors import ConfigError
from sacflow.solver.state import VOLUME_FIELDS

FLOAT32 = [*TINY_INDENT, "output.volume_precision=float32"]


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    out = tmp_path_factory.mktemp("precision")
    runs = {}
    for label, overrides in (("float64", TINY_INDENT), ("float32", FLOAT32)):
        case = sacflow.load_case(INDENT, overrides)
        summary = runner.run_case(case, out / label, progress=False)
        runs[label] = summary.path
    return runs


def test_float32_file_holds_the_float64_results_rounded_once(both):
    with sacflow.open_run(both["float64"]) as f64, sacflow.open_run(both["float32"]) as f32:
        for name in VOLUME_FIELDS:
            if name not in f64:
                continue
            assert f32[name].dtype == np.float32, name
            exact = f64[name].values
            rounded = f32[name].values
            np.testing.assert_array_equal(rounded, exact.astype(np.float32), err_msg=name)
            finite = np.isfinite(exact) & (exact != 0)
            relative = np.abs(rounded[finite].astype(float) - exact[finite]) / np.abs(
                exact[finite])
            assert relative.max(initial=0.0) <= 2.0**-24, name
        for name in ("pressure", "load", "approach"):  # surface fields and scalars: float64
            assert f32[name].dtype == np.float64
            np.testing.assert_array_equal(f32[name].values, f64[name].values)
    assert both["float32"].stat().st_size < 0.8 * both["float64"].stat().st_size


def test_float32_run_resumes_exactly(tmp_path, both):
    case = sacflow.load_case(INDENT, FLOAT32)
    interrupt(case, tmp_path, after=3)
    runner.run_case(case, tmp_path, progress=False)
    with sacflow.open_run(tmp_path / f"{case.name}.nc") as resumed, \
            sacflow.open_run(both["float32"]) as reference:
        assert_same_run(resumed, reference)


def test_defaults_keep_the_case_id_and_float32_changes_it():
    plain = sacflow.load_case(INDENT, TINY_INDENT)
    explicit = sacflow.load_case(INDENT, [*TINY_INDENT, "output.volume_precision=float64"])
    assert plain.case_id == explicit.case_id
    assert sacflow.load_case(INDENT, FLOAT32).case_id != plain.case_id


def test_every_step_fields_are_stored_at_every_step(tmp_path):
    overrides = [*TINY_INDENT, "output.volume_every=3",
                 'output.every_step=["equivalent_plastic_strain"]']
    case = sacflow.load_case(INDENT, overrides)
    path = runner.run_case(case, tmp_path, progress=False).path
    with sacflow.open_run(path) as run:
        steps = run.sizes["step"]
        stored = [bool(np.isfinite(run["equivalent_plastic_strain"][k]).any())
                  for k in range(steps)]
        assert all(stored)
        stress_steps = [k for k in range(steps) if np.isfinite(run["stress"][k]).any()]
        assert stress_steps == [2, 5]  # every third step and the last (6 steps)


def test_every_step_must_be_stored(tmp_path):
    with pytest.raises(ConfigError, match="every_step"):
        sacflow.load_case(INDENT, [*TINY_INDENT, 'output.fields=["load","stress"]',
                                   'output.every_step=["equivalent_plastic_strain"]'])


def test_every_step_names_volume_fields():
    with pytest.raises(ConfigError, match="every_step"):
        sacflow.load_case(INDENT, [*TINY_INDENT, 'output.every_step=["pressure"]'])
