"""``sacflow.studies.edge_phase``: a scan's zigzag split into a line and the edge's phase.

Checked on manufactured scans: a line plus one period of a known radius's phase is recovered
exactly, and the phase of a different radius, or none, leaves a residual."""

from __future__ import annotations

import numpy as np
import pytest

from sacflow.studies.edge_phase import phase_fit

COUNTS = np.arange(120, 138, 2)


def phase(radius_over_width: float, counts: np.ndarray = COUNTS) -> np.ndarray:
    """φ(N) = a/Δx less its nearest whole number, with Δx = width / N."""
    cells = radius_over_width * counts
    return cells - np.round(cells)


def scan(amplitude: float, peak: float, radius_over_width: float) -> np.ndarray:
    """f(N) = 371.9 + 0.001 N + amplitude cos 2π(φ − peak)."""
    return 371.9 + 1e-3 * COUNTS + amplitude * np.cos(
        2.0 * np.pi * (phase(radius_over_width) - peak))


def test_a_line_and_the_phase_are_recovered_exactly():
    got = phase_fit(COUNTS, scan(0.01, 0.2, 0.275), phase(0.275))
    assert got.slope == pytest.approx(1e-3, rel=1e-9)
    assert got.amplitude == pytest.approx(0.01, rel=1e-9)
    assert got.peak_phase == pytest.approx(0.2, abs=1e-9)
    assert got.residual == pytest.approx(0.0, abs=1e-10)
    assert got.explained == pytest.approx(1.0, abs=1e-12)


def test_another_radius_s_phase_leaves_the_zigzag_unexplained():
    """The Hertz radius is a quarter of the window's width; a plastic contact 10 % wider sets
    the zigzag: the Hertz phase (0 or ½ at every even count) cannot explain it."""
    values = scan(0.01, 0.0, 0.275)
    own = phase_fit(COUNTS, values, phase(0.275))
    hertz = phase_fit(COUNTS, values, phase(0.25))
    assert own.explained > 0.999
    assert hertz.explained < 0.5
    assert hertz.residual > 10.0 * own.residual


def test_a_smooth_scan_has_nothing_to_explain():
    got = phase_fit(COUNTS, 371.9 + 1e-3 * COUNTS, phase(0.275))
    assert got.spread == pytest.approx(0.0, abs=1e-10)
    assert got.explained == 0.0


@pytest.mark.parametrize("counts, values, phases, words", [
    (COUNTS, np.zeros(3), np.zeros(COUNTS.size), "one length"),
    (COUNTS[:4], np.zeros(4), np.zeros(4), "6 counts or more"),
    (COUNTS, np.zeros(COUNTS.size), np.full(COUNTS.size, 0.7), "-1/2, 1/2"),
])
def test_bad_arguments_are_named(counts, values, phases, words):
    with pytest.raises(ValueError, match=words):
        phase_fit(counts, values, phases)
