"""Memory a run needs, estimated from the case before anything is allocated (issue #14).

A grid too large for the machine must be refused with a clear message by ``sacflow validate``
and before ``sacflow run`` allocates its operators, not end in numpy's ``_ArrayMemoryError``
half-way through the set-up. :func:`estimate_memory` derives the peak resident memory of a run
from the shapes of the arrays the solver allocates (:class:`sacflow.solver.simulation.Simulation`)
on its body grid (:func:`~sacflow.solver.layout.body_grid`; a case's is laid out by
:func:`sacflow.config.solver_inputs.estimate_case_memory`):

* the contact compliance (DC-FFT on the contact window,
  :class:`~sacflow.kernels.convolution.Convolution`) and the contact solver's window arrays
  (:mod:`sacflow.mechanics.contact`);
* the pressure → stress operator on the body grid: ``6 nz`` complex kernel spectra on the
  zero-padded body grid, and while it is built the kernel coefficients on that grid;
* for a plastic body, the eigenstrain operator (:class:`~sacflow.kernels.eigenstrain.
  HalfSpaceEigenstrain`): its persistent spectra and buffers
  (:func:`~sacflow.kernels.eigenstrain_memory.operator_bytes`) and the transient of its set-up
  (:func:`~sacflow.kernels.eigenstrain_memory.setup_bytes`); with
  ``solver.traction_beyond_box``, the second, coarse operator of the traction beyond the box
  (:class:`~sacflow.kernels.far_traction.FarTraction`) and its set-up;
* the solver state (plastic strain, residual stress), the working arrays of one increment's
  fixed point, the Anderson history (:mod:`sacflow.solver.anderson`) and the GMRES basis of the
  Newton–Krylov fallback;
* the fields of the per-step states handed to the store: the state being written and the next
  one being made (the runner's loop holds one while the solver makes the next);
* the interpreter and its libraries (numpy, scipy, pyfftw, xarray, netCDF4, and numba for
  plastic bodies), measured.

The body grid of a rolling case is the contact window swept along the track. The estimate is
for the case as given; if plastic strain reaches the bottom of the cuboid box, ``sacflow run``
deepens it 1.5 times (more layers, more memory) and runs again. Calibration (peak resident
memory, ``/usr/bin/time -v sacflow run``, 2-core machine): see :data:`LIBRARY_BYTES` and the
module tests.
"""

from __future__ import annotations

from dataclasses import dataclass

from sacflow.errors import GridTooLargeError
from sacflow.machine.resources import available_memory
from sacflow.solver.layout import BodyGrid
from sacflow.solver.nonlinear import NewtonSettings

__all__ = [
    "MemoryEstimate",
    "MemoryItem",
    "check_memory",
    "estimate_memory",
    "format_bytes",
]

#: Bytes of a float64 and of a complex128.
FLOAT, COMPLEX = 8, 16
#: Tensor components of a stress or strain field.
COMPONENTS = 6
#: Resident memory of the interpreter and the libraries a run loads, before any grid array:
#: measured peak of ``sacflow run`` on a 16 × 16 × 2 case. It depends on how much of the shared
#: libraries' files the page cache holds (llvmlite's is 179 MB). Plastic runs load numba and
#: llvmlite for their compiled passes and returns; elastic runs do not (those are imported where
#: they run). In a freshly installed environment (2026-11-29): hertz-elastic 96 MB (three
#: runs), the plastic nanoindentation-650mN 226 MB (two runs); on 2026-11-25, 90 and 270 MB.
#: The larger figures are kept: the estimate is meant to be the peak or above.
LIBRARY_BYTES = {"elastic": 96 * 2**20, "plastic": 270 * 2**20}
#: Window-sized arrays of the contact solver (pressure, gap, conjugate direction, displacement,
#: its update, masks, the initial gap and the result's copies; :mod:`sacflow.mechanics.contact`).
CONTACT_ARRAYS = 14
#: Volume tensor fields of the plastic state (plastic strain, residual stress) and of one
#: increment's fixed point besides the Anderson history and the GMRES basis
#: (:meth:`sacflow.solver.fixed_point.PlasticFixedPoint.solve`): the iterate, the pressure
#: stress and its reshaped copy, the residual stress of the iterate and their sum, the trial
#: stress and ``2μ x``, the returned increment ``G(x)``, the last evaluation's fields.
PLASTIC_STATE_TENSORS = 2
FIXED_POINT_TENSORS = 9
#: Tensor fields the Anderson mixer holds besides its ``2 × depth`` differences: the last
#: iterate and residual, the residual and the mixed iterate (:class:`sacflow.solver.anderson.
#: AndersonMixer`).
ANDERSON_EXTRA = 4
#: Part of the cuboid box the Anderson history is counted on: it is kept on the support of the
#: plastic strain increment (the plastic zone of the step), measured at 7 % of the box at
#: 128 × 128 × 64 cuboids (benchmarks/scale.py); a quarter leaves room for wider zones.
ANDERSON_SUPPORT = 0.25
#: GMRES restart of the Newton–Krylov fallback (``restart=30`` in the solver): when Anderson
#: stalls, the Krylov basis holds ``restart + 1`` vectors of the plastic-strain size, besides
#: the line search's trial iterate and the return's tangent. Reported as what a stalled step
#: needs (:class:`MemoryEstimate`), not refused: the measured runs rarely need it.
GMRES_RESTART = 30
NEWTON_EXTRA = 3
#: Tensor (6 components) and scalar volume fields of one state with volume output
#: (:class:`sacflow.solver.step_state.StateBuilder`): plastic strain, residual stress and
#: stress; equivalent plastic strain, von Mises and yield stress; a plastic body's state adds
#: the restart copies of the plastic strain and the equivalent plastic strain.
STATE_TENSORS = {"elastic": 3, "plastic": 4}
STATE_SCALARS = {"elastic": 3, "plastic": 4}
#: Surface arrays of one state (five stored surface fields, two restart arrays, work copies).
STATE_SURFACES = 9
#: States alive at once: the one the runner holds while the solver makes the next (or while
#: the store consolidates the run, reading one stored step at a time).
STATES_ALIVE = 2
#: Items named in the error message.
SHOWN_ITEMS = 3


@dataclass(frozen=True)
class MemoryItem:
    """One part of the estimate: a short name, its bytes and what it holds."""

    name: str
    nbytes: int
    what: str


@dataclass(frozen=True)
class MemoryEstimate:
    """Estimated peak resident memory of a run [bytes] and its parts.

    Attributes
    ----------
    total : int
        Estimated peak resident memory of the run process [bytes].
    items : tuple of MemoryItem
        The parts, largest first; they add up to ``total``.
    grid : BodyGrid
        The grid the estimate is for.
    stalled : int
        The peak if the plastic fixed point stalls and its Newton–Krylov fallback allocates
        its Krylov basis (``contingent``): reported, not refused (a run that needs it and
        cannot have it stops with a memory error at that step, its earlier steps stored).
    contingent : MemoryItem or None
        That basis.
    """

    total: int
    items: tuple[MemoryItem, ...]
    grid: BodyGrid
    stalled: int = 0
    contingent: MemoryItem | None = None

    def biggest(self, count: int = SHOWN_ITEMS) -> tuple[MemoryItem, ...]:
        """Return the ``count`` largest items."""
        return self.items[:count]

    def short(self) -> str:
        """``"1.2 GiB (largest: eigenstrain operator 800 MiB)"``, for the validate line."""
        top = self.items[0]
        text = f"{format_bytes(self.total)} (largest: {top.name} {format_bytes(top.nbytes)}"
        if self.stalled > self.total:
            text += f"; {format_bytes(self.stalled)} if the fixed point stalls"
        return text + ")"


def format_bytes(nbytes: float) -> str:
    """Bytes in binary units with three significant digits (``"412 MiB"``, ``"1.53 TiB"``)."""
    value = float(nbytes)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if value < 1000.0 or unit == "TiB":
            return f"{value:.3g} {unit}" if unit != "B" else f"{int(value)} B"
        value /= 1024.0
    raise AssertionError("unreachable")  # pragma: no cover


def _real_fft_bytes(batch: int, n1: int, n2: int) -> int:
    """Buffers of a :class:`~sacflow.kernels.fft.RealFFT` of ``batch`` real (n1, n2) planes."""
    return batch * (FLOAT * n1 * n2 + COMPLEX * n1 * (n2 // 2 + 1))


def _contact(grid: BodyGrid, subcells: int = 1) -> MemoryItem:
    """Compliance spectra and buffers on the contact window, the contact solver's arrays.

    With ``subcells`` > 1 the contact is solved on that many sub-cells per cell and axis
    (:mod:`sacflow.solver.subcell_contact`), and its grid is that many times finer.
    """
    from sacflow.kernels.convolution import padded_length

    nx, ny = (n * subcells for n in grid.window)
    p1, p2 = padded_length(nx, nx), padded_length(ny, ny)
    spectra = COMPLEX * p1 * (p2 // 2 + 1)
    nbytes = spectra + 2 * _real_fft_bytes(1, p1, p2) + CONTACT_ARRAYS * FLOAT * nx * ny
    return MemoryItem("contact operator", nbytes,
                      f"compliance spectra and contact arrays on the {nx} × {ny} "
                      + ("window" if subcells == 1 else "sub-cells of the window"))


def _pressure_stress(grid: BodyGrid, inputs: int = 1, name: str = "pressure-stress",
                     kernels: int | None = None) -> tuple[MemoryItem, MemoryItem]:
    """Size the pressure → stress operator (spectra, buffers) and the coefficients of its set-up.

    ``inputs`` pressures per cell: 1 for the cells' pressure, s² for the sub-cells' of a
    contact on s × s sub-cells
    (:meth:`~sacflow.solver.operators.Operators.subcell_pressure_stress`); ``kernels`` of them
    with their own spectra (default all; ⌈s/2⌉² for the sub-cells' without friction,
    :class:`~sacflow.kernels.subcell_stress.MirroredSubcellStress`).
    """
    from sacflow.kernels.convolution import padded_length

    n1, n2 = grid.body
    p1, p2 = padded_length(n1, n1), padded_length(n2, n2)
    outputs = COMPONENTS * grid.nz * (inputs if kernels is None else kernels)
    spectra = outputs * COMPLEX * p1 * (p2 // 2 + 1)
    buffers = _real_fft_bytes(inputs, p1, p2) + 2 * _real_fft_bytes(COMPONENTS, p1, p2)
    operator = MemoryItem(f"{name} operator", spectra + buffers,
                          f"{outputs} kernel spectra on the {p1} × {p2} padded body grid")
    setup = MemoryItem(f"{name} set-up", outputs * FLOAT * p1 * p2,
                       "its kernel coefficients, while they are transformed")
    return operator, setup


def _eigenstrain(grid: BodyGrid) -> tuple[MemoryItem, MemoryItem]:
    """Size the eigenstrain operator's persistent spectra and buffers, and its set-up transient.

    Persistent (:class:`~sacflow.kernels.eigenstrain.HalfSpaceEigenstrain`), per depth
    frequency: the 21 pair spectra and the 18 surface and correction spectra, all real and on
    half the lateral rows, and the one transform buffer, (6, L1, L2) real and its spectrum
    (:func:`~sacflow.kernels.eigenstrain_memory.operator_bytes`).
    """
    from sacflow.kernels.eigenstrain_memory import operator_bytes, padded_lengths, setup_bytes

    shape = (*grid.body, grid.nz)
    l1, l2, n = padded_lengths(shape)
    operator = MemoryItem(
        "eigenstrain operator", operator_bytes(shape),
        f"residual stress/displacement spectra of {shape[0]} × {shape[1]} × {shape[2]} cuboids "
        f"({n + 1} depth frequencies of {l1} × {l2})",
    )
    setup = MemoryItem("eigenstrain set-up", setup_bytes(shape),
                       "kernel fields and spectra while the operator is built")
    return operator, setup


def _far_traction(grid: BodyGrid, cell: tuple[float, float]
                  ) -> tuple[MemoryItem, MemoryItem]:
    """Size the coarse, wider operator of the traction beyond the box, and its set-up.

    :class:`~sacflow.kernels.far_traction.FarTraction`: an eigenstrain operator of super-cells
    on a footprint three times the box's, and the stress it adds (one volume tensor field,
    kept from the first half of an application to the second). Its margins depend on the
    cells' lateral sizes ``cell`` (d1, d2) [m].
    """
    from sacflow.kernels.eigenstrain_memory import operator_bytes, setup_bytes
    from sacflow.kernels.far_traction import FarTraction

    shape = FarTraction.shape_for((*grid.body, grid.nz), cell)
    operator = MemoryItem(
        "far-traction operator", operator_bytes(shape) + _tensor_bytes(grid),
        f"the traction beyond the box: {shape[0]} × {shape[1]} × {shape[2]} super-cells",
    )
    setup = MemoryItem("far-traction set-up", setup_bytes(shape),
                       "its kernel fields and spectra while it is built")
    return operator, setup


def _tensor_bytes(grid: BodyGrid) -> int:
    """Bytes of one volume tensor field (6 components) on the body grid."""
    return COMPONENTS * FLOAT * grid.body[0] * grid.body[1] * grid.nz


def _solver_state(grid: BodyGrid, anderson_depth: int) -> tuple[MemoryItem, MemoryItem]:
    """Plastic state, one increment's fixed point and Anderson history; the GMRES basis.

    The Anderson history is kept on the support of the plastic strain increment
    (:class:`sacflow.solver.anderson.AndersonMixer`), counted as :data:`ANDERSON_SUPPORT` of the
    box; ``anderson_depth`` is 0 without Anderson mixing.
    """
    tensor = _tensor_bytes(grid)
    depth = anderson_depth
    fields = (PLASTIC_STATE_TENSORS + 1 / COMPONENTS + FIXED_POINT_TENSORS
              + (2 * depth + ANDERSON_EXTRA) * ANDERSON_SUPPORT)
    state = MemoryItem(
        "solver state", int(fields * tensor),
        f"plastic state, fixed point and Anderson history (depth {depth}, on the plastic "
        f"zone): {fields:.0f} volume tensor fields",
    )
    krylov = GMRES_RESTART + 1 + NEWTON_EXTRA
    # a stalled history is deepened to NewtonSettings.stall_depth before Newton takes over
    deepened = 2 * max(NewtonSettings.stall_depth - depth, 0) * ANDERSON_SUPPORT if depth else 0
    newton = MemoryItem("stalled fixed point", int((krylov + deepened) * tensor),
                        f"if the fixed point stalls: the Anderson history deepened to "
                        f"{NewtonSettings.stall_depth} ({deepened:.1f} volume tensor fields on "
                        f"the plastic zone) and the Newton-Krylov basis ({krylov})")
    return state, newton


def _states(grid: BodyGrid, plastic: bool) -> MemoryItem:
    """Per-step fields handed to the store (:data:`STATES_ALIVE` states at once)."""
    n1, n2 = grid.body
    kind = "plastic" if plastic else "elastic"
    scalar = FLOAT * n1 * n2 * grid.nz
    one = ((STATE_TENSORS[kind] * COMPONENTS + STATE_SCALARS[kind]) * scalar
           + STATE_SURFACES * FLOAT * n1 * n2)
    return MemoryItem(
        "per-step fields", STATES_ALIVE * one,
        f"the fields of the step being stored and of the next ({n1} × {n2} × {grid.nz} cells)",
    )


def estimate_memory(grid: BodyGrid, plastic: bool, anderson_depth: int,
                    far_traction: tuple[float, float] | None = None,
                    contact_subcells: int = 1, friction: bool = False) -> MemoryEstimate:
    """Estimated peak resident memory of a run [bytes], by item.

    The peak is that of the heavier of two phases: the set-up (operators built, with the
    transient of the last one built) and the increments (operators, solver state, fixed point,
    Anderson history, GMRES basis, per-step fields). The items are those of that phase.

    Parameters
    ----------
    grid : BodyGrid
        The run's body grid (:func:`~sacflow.solver.layout.body_grid`).
    plastic : bool
        Whether the body can yield (the eigenstrain operator and the plastic state).
    anderson_depth : int
        Anderson mixing history depth of the plastic fixed point (0: plain sweeps).
    far_traction : (float, float), optional
        The surface cells' sizes (d1, d2) [m] when the eigenstrain operator removes the
        traction beyond the box (``solver.traction_beyond_box``: a second, coarse operator
        whose margins depend on them); None without it.
    contact_subcells : int
        Sub-cells per surface cell and axis of the contact (``solver.contact_subcells``).
    friction : bool
        Whether the contact carries a shear traction: the sub-cells' kernels are then all
        kept, without it a quarter of them (their mirror symmetry).

    Returns
    -------
    MemoryEstimate
        The total and its items (largest first). Derived from the array shapes the solver
        allocates (module docstring); calibrated against measured peaks, on the high side
        (the GMRES basis of a stalled fixed point is counted).
    """
    libraries = MemoryItem(
        "libraries", LIBRARY_BYTES["plastic" if plastic else "elastic"],
        "the interpreter, numpy, scipy, pyfftw, xarray, netCDF4" + (", numba" if plastic else ""),
    )
    contact = _contact(grid, contact_subcells)
    stress_op, stress_setup = _pressure_stress(grid)
    base = [libraries, contact, stress_op]
    phases = [[*base, stress_setup]]  # set-up of the pressure-stress operator
    if contact_subcells > 1:  # and of the sub-cells' pressure's
        kept = None if friction else ((contact_subcells + 1) // 2) ** 2
        subcell_op, subcell_setup = _pressure_stress(grid, contact_subcells**2,
                                                     "sub-cell pressure-stress", kept)
        phases.append([*base, subcell_op, subcell_setup])
        base.append(subcell_op)
    running = [*base, _states(grid, plastic)]
    contingent = None
    if plastic:
        eigen_op, eigen_setup = _eigenstrain(grid)
        phases.append([*base, eigen_op, eigen_setup])
        state, contingent = _solver_state(grid, anderson_depth)
        running += [eigen_op, state]
        if far_traction is not None:
            far_op, far_setup = _far_traction(grid, far_traction)
            phases.append([*base, eigen_op, far_op, far_setup])
            running.append(far_op)
    phases.append(running)
    heaviest = max(phases, key=lambda phase: sum(item.nbytes for item in phase))
    items = sorted(heaviest, key=lambda item: item.nbytes, reverse=True)
    total = sum(item.nbytes for item in items)
    stalled = total if contingent is None else (
        sum(item.nbytes for item in running) + contingent.nbytes)
    return MemoryEstimate(total, tuple(items), grid, max(total, stalled), contingent)


def check_memory(grid: BodyGrid, plastic: bool, anderson_depth: int,
                 available: int | None = None,
                 far_traction: tuple[float, float] | None = None,
                 contact_subcells: int = 1, friction: bool = False) -> MemoryEstimate:
    """Estimate the memory of a run and refuse it when the machine does not have it.

    Parameters
    ----------
    grid, plastic, anderson_depth, far_traction, contact_subcells, friction
        As for :func:`estimate_memory`.
    available : int, optional
        Bytes available; default :func:`available_memory` now.

    Returns
    -------
    MemoryEstimate
        The estimate, when it fits.

    Raises
    ------
    GridTooLargeError
        When the estimate exceeds the available memory; the message gives both, the largest
        items and the fix (fewer cells, a shorter rolled track).
    """
    estimate = estimate_memory(grid, plastic, anderson_depth, far_traction, contact_subcells,
                               friction)
    available = available_memory() if available is None else int(available)
    if estimate.total > available:
        raise GridTooLargeError(_too_large(estimate, available))
    return estimate


def _too_large(estimate: MemoryEstimate, available: int) -> str:
    """One screen: the estimate, the memory available, the largest items and the fix."""
    grid = estimate.grid
    lines = [
        f"the run needs about {format_bytes(estimate.total)} of memory, "
        f"{format_bytes(available)} available; the largest parts:"
    ]
    width = max(len(item.name) for item in estimate.biggest())
    lines += [
        f"  {item.name:<{width}}  {format_bytes(item.nbytes):>9}  {item.what}"
        for item in estimate.biggest()
    ]
    track = "" if grid.body == grid.window else (
        f" or a shorter rolled track (the body grid is {grid.body[0]} × {grid.body[1]} cells "
        f"for a {grid.window[0]} × {grid.window[1]} window)"
    )
    lines.append(
        f"use fewer cells: grid.nx, grid.ny (now {grid.window[0]}, {grid.window[1]}) and grid.nz "
        f"(now {grid.nz}){track}; memory grows with nx · ny · nz"
    )
    return "\n".join(lines)
