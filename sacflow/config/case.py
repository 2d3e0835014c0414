"""The case: one sacflow run, from its bodies to its output (a frozen, hashable model).

A :class:`Case` holds everything that defines a run: the elastic-plastic body (body 1) and its
hardening law, the counter-body, the surface (smooth, dented, measured), the grid, the load path,
the solver options and the output selection. It is frozen and rejects unknown keys; it is
hashable and identified by :attr:`Case.case_id` (:mod:`sacflow.config.identity`), computed once
per case. Sweeps are ``case.model_copy(update=...)``: the copy gets its own id.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from functools import cached_property
from typing import Any, Self

from pydantic import Field, model_validator

from sacflow.config.base import NAME_PATTERN, Model, finite_json
from sacflow.config.bodies import Body, Counterbody, Friction, InitialState, Smooth, Surface
from sacflow.config.case_checks import (
    check_grid,
    check_initial_state,
    check_load_path,
    check_output_fields,
)
from sacflow.config.identity import (
    FileFingerprints,
    case_id_of,
    identity_of,
    read_file_fingerprints,
)
from sacflow.config.inclusion_checks import check_inhomogeneities
from sacflow.config.load_path import Load, Segment
from sacflow.config.materials import Elastic
from sacflow.config.settings import (
    FRICTION_FIELDS,
    INHOMOGENEITY_FIELDS,
    KINEMATIC_FIELDS,
    PLASTIC_FIELDS,
    Grid,
    Output,
    SolverOptions,
)
from sacflow.mechanics.hertz import HertzContact, composite_modulus, effective_radius, hertz_contact
from sacflow.solver.state import SCALAR_FIELDS, SURFACE_FIELDS, VOLUME_FIELDS

__all__ = ["Case", "case_json_schema"]

#: Tables whose change changes the files a case names (and so its file fingerprints).
FILE_TABLES = frozenset({"surface", "initial_state", "body"})


class Case(Model):
    """One run: bodies, surface, grid, load path, solver options, output."""

    name: str = Field(
        pattern=NAME_PATTERN,
        description="case name: letters, digits, '-', '_' and '.' (the output file name)",
    )
    description: str = Field("", description="free text")
    body: Body = Field(description="the elastic-plastic body (table [body])")
    counterbody: Counterbody = Field(description="the counter-body (table [counterbody])")
    surface: Surface = Field(Smooth(), description="surface of body 1, chosen by 'kind'")
    grid: Grid = Field(description="surface cells and cuboid layers (table [grid])")
    load_path: tuple[Segment, ...] = Field(
        min_length=1, description="load path segments ([[load_path]]), each chosen by 'kind'"
    )
    solver: SolverOptions = Field(SolverOptions(), description="tolerances and iteration limits")
    output: Output = Field(Output(), description="what the run file stores")
    initial_state: InitialState | None = Field(
        None, description="start from a stored run's state (table initial_state)"
    )
    friction: Friction | None = Field(
        None, description="shear traction q = μ p on the contact (table [friction])"
    )

    # -- identity ----------------------------------------------------------------------------
    # ``file_fingerprints`` and ``case_id`` are cached properties: computed once, kept in the
    # instance's __dict__ beside the fields (pydantic compares, hashes and dumps the fields
    # only), carried by copies and pickles; an updated copy (model_copy) recomputes them.
    @cached_property
    def file_fingerprints(self) -> FileFingerprints:
        """Fingerprints of the files the case names (measured surface, source run).

        Set where the case enters (:meth:`with_file_fingerprints`); otherwise read once, at the
        first use, by the reader the storage layer installs
        (:func:`~sacflow.config.identity.read_file_fingerprints`). Empty for a case that names
        no file.
        """
        return read_file_fingerprints(self)

    def with_file_fingerprints(self, fingerprints: FileFingerprints) -> Case:
        """Return a copy of the case that knows the fingerprints of the files it names.

        The storage layer calls it where a case enters, after reading the files
        (:func:`sacflow.storage.fingerprints.identified`); the id follows from them.
        """
        copied = super().model_copy()
        copied.__dict__.pop("case_id", None)
        copied.__dict__["file_fingerprints"] = fingerprints  # the cached property's value
        return copied

    def model_copy(self, *, update: Mapping[str, Any] | None = None, deep: bool = False) -> Self:
        """Return a copy (pydantic ``model_copy``); an updated copy gets its own ``case_id``.

        The file fingerprints are kept unless ``update`` changes ``surface``,
        ``initial_state`` or ``body`` (its inhomogeneities' cells files): they are then read
        again at the first use of the id.
        """
        copied = super().model_copy(update=update, deep=deep)
        if update:
            copied.__dict__.pop("case_id", None)
            if FILE_TABLES & set(update):
                copied.__dict__.pop("file_fingerprints", None)
        return copied

    def canonical_json(self) -> str:
        """Return the case as JSON with sorted keys and no spaces (non-finite as strings)."""
        return json.dumps(json.loads(self.model_dump_json()), sort_keys=True, separators=(",", ":"))

    def identity(self) -> dict[str, Any]:
        """Return the fields that determine the stored numbers (:data:`NOT_IN_IDENTITY` left out).

        Nested dict of the case's JSON form without its name, description, thread count and
        compression level, and with a measured surface's file named by the SHA-256 of its
        contents rather than by its path, a source run by its case id
        (:func:`sacflow.config.identity.identity_of`): two cases with the same identity write
        the same numbers.
        """
        return identity_of(json.loads(self.model_dump_json()), self.file_fingerprints)

    @cached_property
    def case_id(self) -> str:
        """First 12 hex digits of the SHA-256 of the canonical JSON of :meth:`identity`.

        It names the run in its file and in campaign manifests; a stored run of another id is
        never overwritten unless asked (``sacflow run --overwrite``). Computed once per case.
        """
        return case_id_of(self.identity())

    # -- derived quantities ------------------------------------------------------------------
    def stored_fields(self) -> tuple[str, ...]:
        """Return the variables the run file stores: ``output.fields`` or the default (Output).

        The default adds the inhomogeneity fields (:data:`INHOMOGENEITY_FIELDS`) for a body
        with inhomogeneities only.
        """
        if self.output.fields is not None:
            return tuple(self.output.fields)
        every = SCALAR_FIELDS + SURFACE_FIELDS + VOLUME_FIELDS
        if self.body.inhomogeneity:
            every += INHOMOGENEITY_FIELDS
        if self.friction is None:
            every = tuple(name for name in every if name not in FRICTION_FIELDS)
        if getattr(self.body.hardening, "kinematic", None) is None:
            every = tuple(name for name in every if name not in KINEMATIC_FIELDS)
        if isinstance(self.body.hardening, Elastic):
            return tuple(name for name in every if name not in PLASTIC_FIELDS)
        return every

    @property
    def max_load(self) -> float:
        """Largest target load of the load segments [N]."""
        return max((s.to for s in self.load_path if isinstance(s, Load)), default=0.0)

    def hertz(self) -> HertzContact:
        """Hertz estimate at :attr:`max_load`.

        Contact modulus of body and counter-body; effective radius per direction from both
        bodies' principal radii, and their geometric mean when the two differ.
        """
        r1, r2 = self.effective_radii()
        return hertz_contact(self.max_load, math.sqrt(r1 * r2), self.contact_modulus())

    def contact_modulus(self) -> float:
        """Contact modulus E* of body and counter-body [Pa] (rigid counter-body: E, ν only)."""
        cb = self.counterbody
        return composite_modulus(self.body.E, self.body.nu, cb.E, cb.nu or 0.0)

    def effective_radii(self) -> tuple[float, float]:
        """Effective radii of curvature (R1, R2) along x1, x2 of the two bodies [m]."""
        r1, r2 = (
            effective_radius(rb, rc)
            for rb, rc in zip(self.body.radii, self.counterbody.principal_radii, strict=True)
        )
        return (r1, r2)

    def window_extent(self) -> tuple[float, float]:
        """Full size (L1, L2) of the contact window [m]."""
        if self.grid.extent is not None:
            return self.grid.extent
        size = 2.0 * self.grid.half_width * self.hertz().a
        return (size, size)

    def cell_size(self) -> tuple[float, float]:
        """Surface cell size (dx1, dx2) [m]."""
        l1, l2 = self.window_extent()
        return (l1 / self.grid.nx, l2 / self.grid.ny)

    # -- case-level checks (sacflow.config.case_checks), in this order -----------------------
    @model_validator(mode="after")
    def _check_load_path(self) -> Case:
        check_load_path(self)
        return self

    @model_validator(mode="after")
    def _check_friction_fields(self) -> Case:
        check_output_fields(self)
        return self

    @model_validator(mode="after")
    def _check_initial_state(self) -> Case:
        check_initial_state(self)
        return self

    @model_validator(mode="after")
    def _check_grid(self) -> Case:
        check_grid(self)
        return self

    @model_validator(mode="after")
    def _check_inhomogeneities(self) -> Case:
        check_inhomogeneities(self)
        return self


def case_json_schema() -> dict[str, Any]:
    """Return the JSON schema of :class:`Case`, strictly valid JSON (no bare Infinity)."""
    return finite_json(Case.model_json_schema())
