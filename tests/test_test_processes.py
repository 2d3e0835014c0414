"""How many processes ``pytest -n auto`` starts (tests/conftest.py's pytest-xdist hook)."""

from __future__ import annotations

import pytest
from conftest import MAX_TEST_WORKERS, pytest_xdist_auto_num_workers

from sacflow.machine import resources


def test_one_process_per_usable_core_up_to_the_cap(monkeypatch: pytest.MonkeyPatch) -> None:
    """The count follows the affinity mask and stops at :data:`MAX_TEST_WORKERS`."""
    monkeypatch.delenv("PYTEST_XDIST_AUTO_NUM_WORKERS", raising=False)
    for cores in (1, 2, MAX_TEST_WORKERS + 3):
        monkeypatch.setattr("conftest.usable_cores", lambda cores=cores: cores)
        assert pytest_xdist_auto_num_workers(None) == min(cores, MAX_TEST_WORKERS)  # type: ignore[arg-type]


def test_the_environment_variable_still_decides(monkeypatch: pytest.MonkeyPatch) -> None:
    """``PYTEST_XDIST_AUTO_NUM_WORKERS`` wins, as it does in pytest-xdist's own hook."""
    monkeypatch.setenv("PYTEST_XDIST_AUTO_NUM_WORKERS", "7")
    assert pytest_xdist_auto_num_workers(None) == 7  # type: ignore[arg-type]
    monkeypatch.setenv("PYTEST_XDIST_AUTO_NUM_WORKERS", "many")
    assert pytest_xdist_auto_num_workers(None) == min(  # type: ignore[arg-type]
        resources.usable_cores(), MAX_TEST_WORKERS)
