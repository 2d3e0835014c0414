"""How flat the press's largest εp is: what an error of its depth stands for.

``python pipelines/press_plastic_peak.py RUN.nc [--table CSV [--overwrite]]``

RUN.nc is a finished run of the press of the indentation-made dent (``sacflow run
pipelines/dent-from-indentation-press.toml``, whose volume fields are stored at its last step).
The convergence study certifies its largest εp and the depth of it
(``data/convergence-certified.csv``); this script reads the last step's εp and measures the
maximum's shape (:func:`sacflow.studies.plastic_peak.peak_shape`): the depth parabola through
the largest cell's column, its distance from the load axis (the press's vertical load acts at
x1 = x2 = 0) against the largest contact radius of the run, √(area / π), and the spread of the
ring of cells round the axis at its layer. With the certificate's limit of the depth it prints
how far below its vertex the parabola lies there (the error of εp that the depth's error stands
for), and how far it falls over half a percent of the depth (the resolution of εp that a depth
within the study's target asks). It also measures where the run flowed at all
(:func:`sacflow.studies.plastic_peak.plastic_extent`): the share of the box's cells with
εp > 0, and the smallest square box about the axis that holds them, against the box, by its
half width, its depth and its volume (what finer cells confined to the flow would still have to
cover). ``--table`` writes the numbers (quantity, value, unit;
refused if the file exists, unless ``--overwrite``).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

import numpy as np

from sacflow.errors import SacflowError
from sacflow.studies.convergence_table import TARGET_ERROR, add_table_arguments, write_csv
from sacflow.studies.plastic_peak import peak_shape, plastic_extent

DATA = Path(__file__).resolve().parents[1] / "data"
#: The press's case in the certificate, and the certified quantity whose limit is read.
CASE, DEPTH = "dent-from-indentation-press", "max_plastic_strain_refined_depth"
COLUMNS = ("quantity", "value", "unit")
#: What the run file must store: the last step's εp and the contact area of every step.
NEEDED = ("equivalent_plastic_strain", "contact_area")


def certified_depth(table: Path = DATA / "convergence-certified.csv") -> tuple[float, float]:
    """The press's certified limit of the largest εp's depth and its shipped value [m]."""
    try:
        with table.open(encoding="utf-8") as f:
            for row in csv.DictReader(f):
                if row.get("case") == CASE and row.get("quantity") == DEPTH:
                    return float(row["limit"]), float(row["shipped_value"])
    except OSError as err:
        raise SacflowError(f"cannot read the certificate {table}: {err}; regenerate it with "
                           "python pipelines/convergence_certify.py --table "
                           "data/convergence-certified.csv") from err
    raise SacflowError(f"{table} has no row for {CASE} {DEPTH}")


def measure_run(path: Path) -> list[dict[str, object]]:
    """The rows of the table for the run file ``path``."""
    import xarray as xr

    try:
        ds = xr.open_dataset(path)
    except (OSError, ValueError) as err:
        raise SacflowError(f"cannot read {path} as a run file: {err}") from err
    with ds:
        missing = [name for name in NEEDED if name not in ds]
        if missing:
            raise SacflowError(f"{path} stores no {', '.join(missing)}: run the press with "
                               "its shipped [output] fields")
        last = ds["equivalent_plastic_strain"].isel(step=-1).transpose("x1", "x2", "x3")
        field = np.asarray(last.values, dtype=float)
        x1, x2, x3 = (np.asarray(ds[c].values, dtype=float) for c in ("x1", "x2", "x3"))
        contact = math.sqrt(float(ds["contact_area"].max()) / math.pi)
    if not np.nanmax(field, initial=0.0) > 0.0:
        raise SacflowError(f"{path}: no plastic strain at its last step, so no maximum to "
                           "measure")
    shape = peak_shape(field, x1, x2, x3)
    extent = plastic_extent(field, x1, x2, x3)
    limit, shipped = certified_depth()
    rows = {
        "largest_eqps_refined": (shape.value, "1"), "its_depth": (shape.depth, "m"),
        "radius": (shape.radius, "m"), "contact_radius": (contact, "m"),
        "radius_over_contact_radius": (shape.radius / contact, "1"),
        "layer": (shape.layer, "m"), "one_layer_above": (shape.above, "1"),
        "one_layer_below": (shape.below, "1"), "depth_curvature": (shape.curvature, "1/m2"),
        "ring_spread": (shape.ring_spread, "1"), "certified_depth_limit": (limit, "m"),
        "certified_shipped_depth": (shipped, "m"),
        "drop_at_certified_limit": (shape.drop_at(limit), "1"),
        "shipped_minus_limit": (shipped - limit, "m"),
        "drop_over_half_percent_of_depth": (
            shape.drop_at(shape.depth + TARGET_ERROR * limit), "1"),
        "plastic_share": (extent.share, "1"), "plastic_half_width": (extent.half_width, "m"),
        "box_half_width": (extent.box_half_width, "m"), "plastic_depth": (extent.depth, "m"),
        "box_depth": (extent.box_depth, "m"),
        "plastic_subbox_volume_share": (extent.volume_share, "1"),
    }
    return [{"quantity": k, "value": f"{v:.10g}", "unit": u} for k, (v, u) in rows.items()]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="a finished run file of the press (netCDF)")
    add_table_arguments(parser)
    args = parser.parse_args(argv)
    try:
        rows = measure_run(args.run)
        if args.table is not None:
            write_csv(args.table, rows, COLUMNS, args.overwrite)
    except (SacflowError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    for row in rows:
        print(f"{row['quantity']:28s} {row['value']:>16s} {row['unit']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
