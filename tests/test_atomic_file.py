"""Whole or absent: ``sacflow.storage.atomic_file.write_atomically``."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from matplotlib.figure import Figure

from sacflow.storage.atomic_file import temporary_name, write_atomically


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "table.csv"
    target.write_text("old\n")

    def half_then_fail(tmp):
        tmp.write_text("half of the new")
        raise RuntimeError("killed mid-write")

    with pytest.raises(RuntimeError, match="killed mid-write"):
        write_atomically(target, half_then_fail)
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.csv"]


def test_the_new_file_replaces_the_old_and_the_folder_is_made(tmp_path):
    target = tmp_path / "new" / "surface.txt"
    assert write_atomically(target, lambda tmp: tmp.write_text("1 2 3\n")) == target
    assert target.read_text() == "1 2 3\n"
    write_atomically(target, lambda tmp: tmp.write_text("4 5 6\n"))
    assert target.read_text() == "4 5 6\n"
    assert sorted(p.name for p in target.parent.iterdir()) == ["surface.txt"]


def test_writers_that_choose_the_format_from_the_suffix_still_do(tmp_path):
    assert temporary_name(tmp_path / "a.png").suffix == ".png"
    assert temporary_name(tmp_path / "a.png").name.startswith(".")
    fig = Figure()
    fig.subplots().plot([0, 1], [1, 0])
    png = write_atomically(tmp_path / "plot.png", lambda tmp: fig.savefig(tmp, dpi=20))
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    data = xr.Dataset({"x": ("i", np.arange(3.0))})
    nc = write_atomically(tmp_path / "data.nc", data.to_netcdf)
    with xr.open_dataset(nc) as back:
        np.testing.assert_array_equal(back["x"].values, np.arange(3.0))
