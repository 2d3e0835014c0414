"""Run one case: build the simulation, stream its states into the run file, report.

The simulation contract (``sacflow.solver.Simulation``): ``sim = Simulation(case)``;
``sim.coords`` is a :class:`~sacflow.state.GridCoords`; ``sim.total_steps`` an int; ``sim.run()``
a generator of :class:`~sacflow.state.State`, raising a :class:`~sacflow.errors.SacflowError` on
failure. Runs resume: a finished run file of the same case is kept as is, and the steps of an
interrupted run are not written again.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from tqdm.auto import tqdm

from sacflow.errors import BoxTooShallowError
from sacflow.schema import Case
from sacflow.state import GridCoords, State
from sacflow.store import RunWriter, completed_steps, is_complete, read_scalars

__all__ = ["RunSummary", "Simulation", "run", "run_case"]


class Simulation(Protocol):
    """What :func:`run_case` needs from a simulation."""

    coords: GridCoords
    total_steps: int

    def run(self) -> Iterator[State]:
        """Yield one converged state per increment."""
        ...


@dataclass(frozen=True)
class RunSummary:
    """Outcome of one run; load, approach, max pressure and area are those of the last step."""

    name: str
    case_id: str
    path: Path
    steps: int
    wall_time: float
    resumed_steps: int
    skipped: bool
    load: float
    approach: float
    max_pressure: float
    contact_area: float

    def line(self) -> str:
        """One-line human summary."""
        if self.skipped:
            status = f"already complete, {self.steps} steps"
        else:
            resumed = f" (resumed after {self.resumed_steps})" if self.resumed_steps else ""
            status = f"{self.steps} steps{resumed} in {self.wall_time:.1f} s"
        return (
            f"{self.name} ({self.case_id}): {status}; last step W = {self.load:.4g} N, "
            f"p_max = {self.max_pressure / 1e9:.4g} GPa, approach = {self.approach * 1e6:.4g} µm "
            f"-> {self.path}"
        )


def run_case(
    case: Case,
    out_dir: str | Path,
    *,
    progress: bool = True,
    simulation_factory: Callable[[Case], Simulation] | None = None,
    resume: bool = True,
) -> RunSummary:
    """Run ``case`` and write ``out_dir/<case.name>.nc``.

    Parameters
    ----------
    case : Case
        The validated case.
    out_dir : str or Path
        Output folder (created if needed).
    progress : bool
        Show a progress bar (load, max pressure, contact/plasticity iterations).
    simulation_factory : callable, optional
        ``factory(case) -> simulation``; default ``sacflow.solver.Simulation``.
    resume : bool
        Skip a finished run of the same case; keep the steps of an interrupted one (the
        simulation is replayed up to them without writing). ``False`` starts afresh.

    Raises
    ------
    SacflowError
        When the simulation fails; the steps stored so far are kept.
    """
    start = time.perf_counter()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{case.name}.nc"
    if resume and is_complete(path, case.case_id):
        return _summary(case, path, start, resumed=0, skipped=True)
    requested = case.case_id
    factory = simulation_factory or _default_factory()
    for growth in range(_MAX_GROWTHS + 1):
        try:
            done = _run_once(case, path, factory, progress, resume, requested)
            break
        except BoxTooShallowError as exc:
            if growth == _MAX_GROWTHS:
                raise
            case = _deeper(case, exc)
            message = (f"{case.name}: plastic strain reached the bottom of the cuboid box at step "
                       f"{exc.step}; running again with depth {exc.depth:.4g} -> "
                       f"{exc.new_depth:.4g} m ({exc.nz} -> {exc.new_nz} layers)")
            warnings.warn(message, RuntimeWarning, stacklevel=2)
            if progress:
                tqdm.write(message)
    return _summary(case, path, start, resumed=done, skipped=False)


#: How many times a run may deepen its cuboid box (×1.5 each) before giving up.
_MAX_GROWTHS = 3


def _run_once(
    case: Case,
    path: Path,
    factory: Callable[[Case], Simulation],
    progress: bool,
    resume: bool,
    requested: str,
) -> int:
    """One attempt of :func:`run_case`; returns the number of steps resumed (not rewritten)."""
    sim = factory(case)
    done = completed_steps(path, case.case_id) if resume else 0
    writer = RunWriter(
        path,
        case,
        sim.coords,
        fields=case.output.fields,
        compression=case.output.compression,
        resume=resume,
        requested_case_id=requested,
    )
    bar = tqdm(total=sim.total_steps, desc=case.name, unit="step", disable=not progress)
    with bar, writer:
        for index, state in enumerate(sim.run()):
            if index >= done:
                writer.append(state)
            bar.set_postfix(_postfix(state), refresh=False)
            bar.update()
    return done


def _deeper(case: Case, exc: BoxTooShallowError) -> Case:
    """``case`` with the deeper cuboid box that ``exc`` asks for."""
    data = case.model_dump()
    data["grid"] = {**data["grid"], "depth": exc.new_depth, "nz": exc.new_nz}
    return Case.model_validate(data)


def _default_factory() -> Callable[[Case], Simulation]:
    from sacflow.solver import Simulation as SolverSimulation  # the solver loads lazily

    return SolverSimulation


def _postfix(state: State) -> dict[str, str]:
    return {
        "load": f"{state.load:.3g} N",
        "p_max": f"{state.max_pressure / 1e9:.3g} GPa",
        "iter": f"{state.contact_iterations}/{state.plasticity_iterations}",
    }


def _summary(case: Case, path: Path, start: float, resumed: int, skipped: bool) -> RunSummary:
    scalars = read_scalars(path)

    def last(name: str) -> float:
        values = scalars.get(name)
        return float(values[-1]) if values is not None and len(values) else float("nan")

    return RunSummary(
        name=case.name,
        case_id=case.case_id,
        path=path,
        steps=completed_steps(path),
        wall_time=time.perf_counter() - start,
        resumed_steps=resumed,
        skipped=skipped,
        load=last("load"),
        approach=last("approach"),
        max_pressure=last("max_pressure"),
        contact_area=last("contact_area"),
    )


def run(case: Case | str | Path, out_dir: str | Path = "runs", *, progress: bool = True, **kwargs):
    """Notebook entry point: run ``case`` (a Case or a config path) and open the result.

    Writes ``out_dir/<case.name>.nc`` like ``sacflow run`` (resuming a partial run) and returns
    the :class:`xarray.Dataset` from :func:`sacflow.store.open_run`.
    """
    from sacflow.config import load_case
    from sacflow.store import open_run

    if not isinstance(case, Case):
        case = load_case(case)
    summary = run_case(case, out_dir, progress=progress, **kwargs)
    return open_run(summary.path)
