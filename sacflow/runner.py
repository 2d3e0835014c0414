"""Run one case: build the simulation, stream its states into the run file, report.

The simulation contract (:class:`StateSource`; the solver's is
:class:`sacflow.solver.simulation.Simulation`, made by
:func:`sacflow.config.solver_inputs.simulation_for`): ``sim = factory(case)``; ``sim.coords``
is a :class:`~sacflow.solver.state.GridCoords`; ``sim.total_steps`` an int; ``sim.run()`` a
generator of :class:`~sacflow.solver.state.State`, raising a
:class:`~sacflow.errors.SacflowError` on failure. A simulation that can go on from a stored
state also has ``restore(step, arrays, first_contact_offset)`` and ``run(start=step + 1)``; its
states carry that state (``State.restart``).

Runs are never lost and never silently replaced: a finished run file of the same case is kept as
is; an interrupted one goes on after its last sound stored step (true resume, from the stored
solver state; damaged step parts are named and dropped); a run of another case stored under the
same name is replaced only when asked (``overwrite``), otherwise the error names both ids and
the fields that differ.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from tqdm.auto import tqdm

from sacflow.config.schema import Case
from sacflow.config.solver_inputs import check_case_memory
from sacflow.errors import BoxTooShallowError
from sacflow.solver.state import GridCoords, State
from sacflow.storage.output_dir import prepare_output_dir
from sacflow.storage.run_reader import RunInfo, read_scalars, run_info
from sacflow.storage.run_writer import RunExistsError, RunWriter, replace_message

__all__ = ["RunSummary", "StateSource", "run", "run_case"]


class StateSource(Protocol):
    """What :func:`run_case` needs from a simulation: its grid, its steps, their states."""

    coords: GridCoords
    total_steps: int

    def run(self, start: int = 0) -> Iterator[State]:
        """Yield one converged state per increment (from ``start``, after ``restore``)."""
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
    simulation_factory: Callable[[Case], StateSource] | None = None,
    resume: bool = True,
    overwrite: bool = False,
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
        ``factory(case) -> simulation``; default
        :func:`sacflow.config.solver_inputs.simulation_for` (with the case's measured surface
        and stored initial state read).
    resume : bool
        Skip a finished run of the same case; go on after the stored steps of an interrupted
        one, from the solver state stored with the last sound step (a simulation without
        ``restore`` is replayed up to it without writing). ``False`` recomputes the case from
        its first step, replacing its stored steps (asked for: ``sacflow run --restart``).
    overwrite : bool
        Replace a run of *another* case stored under the same name. Without it such a run,
        finished or interrupted, is left as it is and
        :class:`~sacflow.storage.run_writer.RunExistsError`
        says how it differs.

    Raises
    ------
    SacflowError
        When the simulation fails; the steps stored so far are kept.
    RunExistsError
        When ``out_dir/<case.name>.nc`` holds a run of another case and ``overwrite`` is false.
    """
    start = time.perf_counter()
    path = Path(out_dir) / f"{case.name}.nc"
    prepare_output_dir(out_dir)
    info = run_info(path)
    same = info.exists and info.matches(case.case_id)
    if info.complete and same and resume:
        return _summary(case, info, start, resumed=0, skipped=True)
    if info.exists and not same and not info.damaged_only and not overwrite:
        raise RunExistsError(replace_message(info, case))
    requested = case.case_id
    if same and resume and info.parts and info.case is not None:
        case = info.case  # an interrupted run goes on as stored (its box may have been grown)
    keep = len(info.parts) if same and resume and not info.complete else 0
    if info.damaged:
        _say(f"{case.name}: dropped damaged steps ({info.problem}): "
             + ", ".join(p.name for p in info.damaged), progress)
    factory = simulation_factory or _default_factory()
    for growth in range(_MAX_GROWTHS + 1):
        try:
            done = _run_once(case, info, factory, progress, keep, requested)
            break
        except BoxTooShallowError as exc:
            if growth == _MAX_GROWTHS:
                raise
            case = _deeper(case, exc)
            _say(f"{case.name}: plastic strain reached the bottom of the cuboid box at step "
                 f"{exc.step}; running again with depth {exc.depth:.4g} -> "
                 f"{exc.new_depth:.4g} m ({exc.nz} -> {exc.new_nz} layers)", progress,
                 warn=True)
            info, keep = run_info(path), 0  # this run's own steps, of the shallower box
    return _summary(case, run_info(path), start, resumed=done, skipped=False)


#: How many times a run may deepen its cuboid box (×1.5 each) before giving up.
_MAX_GROWTHS = 3
#: Estimated memory above which the run says it is setting up: the operators' set-up of such
#: grids is long (docs/performance.md).
SETUP_NOTICE_BYTES = 2 << 30


def _run_once(
    case: Case,
    info: RunInfo,
    factory: Callable[[Case], StateSource],
    progress: bool,
    keep: int,
    requested: str,
) -> int:
    """One attempt of :func:`run_case`: steps ``keep`` onwards; returns ``keep``.

    Everything stored at the path beyond the first ``keep`` steps is replaced: the caller has
    checked it may be (same case asked afresh, ``overwrite``, or this run's own earlier try).
    """
    estimate = check_case_memory(case)  # refuse before allocating what the machine cannot hold
    if progress and estimate.total > SETUP_NOTICE_BYTES:  # a long set-up
        grid = estimate.grid
        _say(f"{case.name}: setting up the operators of {grid.body[0]} × {grid.body[1]} × "
             f"{grid.nz} cells (kernel spectra from the cache if this grid ran before)",
             progress)
    sim = factory(case)
    restart = info.restart() if keep else None
    restore = getattr(sim, "restore", None)
    writer = RunWriter(
        info.path, case, sim.coords, fields=case.stored_fields(),
        compression=case.output.compression, keep_steps=keep, overwrite=True,
        requested_case_id=requested, info=info,
    )
    if restart is not None and restore is not None:
        restore(keep - 1, *restart)
        states, first = sim.run(start=keep), keep  # true resume
    else:
        states, first = sim.run(), 0  # replay the stored steps without writing them
    bar = tqdm(total=sim.total_steps, initial=first, desc=case.name, unit="step",
               disable=not progress)
    with bar, writer:
        for index, state in enumerate(states, first):
            if index >= keep:
                writer.append(state)
            bar.set_postfix(_postfix(state), refresh=False)
            bar.update()
    return keep


def _say(message: str, progress: bool, warn: bool = False) -> None:
    """Tell the user: a warning (``warn``) and, with a progress bar, a line above it."""
    if warn:
        warnings.warn(message, RuntimeWarning, stacklevel=3)
    if progress or not warn:
        tqdm.write(message)


def _deeper(case: Case, exc: BoxTooShallowError) -> Case:
    """``case`` with the deeper cuboid box that ``exc`` asks for."""
    data = case.model_dump()
    data["grid"] = {**data["grid"], "depth": exc.new_depth, "nz": exc.new_nz}
    return Case.model_validate(data)


def _default_factory() -> Callable[[Case], StateSource]:
    """Return the solver's simulation factory.

    It reads a measured surface, a stored state, the cells files of inhomogeneities.
    """
    from sacflow.config.solver_inputs import simulation_for
    from sacflow.storage.inclusion_cells_file import read_inclusion_cells
    from sacflow.storage.initial_state_file import read_initial_state
    from sacflow.storage.surface_file import load_surface

    def factory(case: Case) -> StateSource:
        return simulation_for(case, surface=load_surface(case),
                              initial=read_initial_state(case),
                              cells=read_inclusion_cells(case))

    return factory


def _postfix(state: State) -> dict[str, str]:
    return {
        "load": f"{state.load:.3g} N",
        "p_max": f"{state.max_pressure / 1e9:.3g} GPa",
        "iter": f"{state.contact_iterations}/{state.plasticity_iterations}",
    }


def _summary(case: Case, info: RunInfo, start: float, resumed: int, skipped: bool) -> RunSummary:
    scalars = read_scalars(info.path)

    def last(name: str) -> float:
        values = scalars.get(name)
        return float(values[-1]) if values is not None and len(values) else float("nan")

    return RunSummary(
        name=case.name,
        case_id=case.case_id,
        path=info.path,
        steps=info.steps,
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
    the :class:`xarray.Dataset` from :func:`sacflow.storage.run_reader.open_run`.

    ``kwargs`` are those of :func:`run_case`: ``resume=False`` recomputes the case from its
    first step (``sacflow run --restart``), ``overwrite=True`` replaces a run of another case
    stored under its name (``--overwrite``), ``simulation_factory`` builds the simulation.
    """
    from sacflow.storage.case_file import load_case
    from sacflow.storage.run_reader import open_run

    if not isinstance(case, Case):
        case = load_case(case)
    summary = run_case(case, out_dir, progress=progress, **kwargs)
    return open_run(summary.path)
