"""Write ``hertz-axis-s11.csv``: the closed-form σ11 on the axis of the ``hertz-elastic`` contact.

    python data/make_hertz_axis.py [OUT_DIR]      (default: this folder)

A reference profile for ``sacflow compare case-vs-reference`` (``docs/compare.md``): the radial
stress σr = σ11 on the axis x1 = x2 = 0 under the Hertz pressure of ``configs/hertz-elastic.toml``
(rigid sphere R = 105 µm on E = 210 GPa, ν = 0.3, W = 0.65 N: a = 6.053 µm, p0 = 8.470 GPa),
from Johnson eq. 3.45 (``sacflow.mechanics.hertz.hertz_axis_stress``), at 41 depths 0.25 µm
apart from 0.5 µm to 10.5 µm (between the centres of the first and last layers of the case's
12.1 µm box). Columns ``x3`` in µm and ``s11`` in MPa (read them with ``--coord-scale 1e-6
--value-scale 1e6``), fixed formatting so that the file is reproduced byte for byte
(``tests/test_doc_numbers.py`` checks it). Nothing here is measured.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
NAME = "hertz-axis-s11.csv"
#: Depths of the profile [µm]: 41 points 0.25 µm apart.
DEPTHS_UM = 0.25 * np.arange(2, 43)


def profile() -> tuple[np.ndarray, np.ndarray]:
    """Return depths [m] and the closed-form σ11 on the axis [Pa] of ``hertz-elastic``."""
    from sacflow.mechanics.hertz import hertz_axis_stress
    from sacflow.storage.case_file import load_case

    case = load_case(ROOT / "configs" / "hertz-elastic.toml")
    hertz = case.hertz()
    x3 = DEPTHS_UM * 1e-6
    sigma_r, _ = hertz_axis_stress(x3, hertz.a, hertz.p0, case.body.nu)
    return x3, sigma_r


def write(out_dir: Path = HERE) -> Path:
    """Write the CSV file into ``out_dir`` and return its path."""
    x3, s11 = profile()
    lines = [
        "# Closed-form sigma11 (= sigma_r) on the axis of configs/hertz-elastic.toml (Hertz, "
        "Johnson eq. 3.45); not measured",
        "# made by: python data/make_hertz_axis.py; x3 in um, s11 in MPa",
        "x3,s11",
        *(f"{z * 1e6:.2f},{s / 1e6:.3f}" for z, s in zip(x3, s11, strict=True)),
    ]
    path = Path(out_dir) / NAME
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


if __name__ == "__main__":
    print(write(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE))
