"""The case schema: the one import point of the models of a sacflow case and campaign.

Callers import every model from here (``from sacflow.config.schema import Case``); the models
live in the modules of :mod:`sacflow.config` by subject:

* :mod:`~sacflow.config.base`: the frozen :class:`Model`, :func:`field_error`, unit types;
* :mod:`~sacflow.config.materials`: hardening laws, kinematic hardening, initial profiles;
* :mod:`~sacflow.config.bodies`: body 1, the counter-body, surfaces, friction, initial state;
* :mod:`~sacflow.config.inclusions`: the elastic inhomogeneities of body 1 (their checks against
  the grid in :mod:`~sacflow.config.inclusion_checks`);
* :mod:`~sacflow.config.load_path`: load, unload, hold and roll segments;
* :mod:`~sacflow.config.settings`: grid, solver options, output;
* :mod:`~sacflow.config.case`: the :class:`Case` and its JSON schema; the case-level checks in
  :mod:`~sacflow.config.case_checks`, the ``case_id`` in :mod:`~sacflow.config.identity`;
* :mod:`~sacflow.config.campaign`: campaign files.

Every model is frozen and rejects unknown keys; a case is hashable and identified by
:attr:`Case.case_id`, the hash of the canonical JSON of what changes its numbers (not its name,
description, thread count or compression level). Sweeps are ``case.model_copy(update=...)``.

Units are SI everywhere: m, Pa, N. ``x3`` is depth, positive into the body. Sequences are stored
as tuples so that a case cannot be changed in place.
"""

from __future__ import annotations

from sacflow.config.base import FIELD_ERROR, NAME_PATTERN, Model, field_error, unit_vector
from sacflow.config.bodies import (
    Body,
    Counterbody,
    Dent,
    Dented,
    Friction,
    InitialState,
    Measured,
    Smooth,
    Surface,
)
from sacflow.config.campaign import Campaign, Sweep, campaign_json_schema
from sacflow.config.case import Case, case_json_schema
from sacflow.config.identity import (
    NOT_IN_IDENTITY,
    OPTIONAL_TABLES,
    FileFingerprints,
    identity_differences,
)
from sacflow.config.inclusions import Inhomogeneity
from sacflow.config.load_path import Hold, Load, Roll, Segment, Unload
from sacflow.config.materials import (
    DepthProfile,
    Elastic,
    HardeningLaw,
    InitialHardening,
    InitialResidualStress,
    KinematicHardening,
    Linear,
    PerfectlyPlastic,
    Swift,
    Tabular,
)
from sacflow.config.settings import (
    FRICTION_FIELDS,
    KINEMATIC_FIELDS,
    PLASTIC_FIELDS,
    Grid,
    Output,
    SolverOptions,
)

__all__ = [
    "FIELD_ERROR",
    "FRICTION_FIELDS",
    "KINEMATIC_FIELDS",
    "NAME_PATTERN",
    "NOT_IN_IDENTITY",
    "OPTIONAL_TABLES",
    "PLASTIC_FIELDS",
    "Body",
    "Campaign",
    "Case",
    "Counterbody",
    "Dent",
    "Dented",
    "DepthProfile",
    "Elastic",
    "FileFingerprints",
    "Friction",
    "Grid",
    "HardeningLaw",
    "Hold",
    "Inhomogeneity",
    "InitialHardening",
    "InitialResidualStress",
    "InitialState",
    "KinematicHardening",
    "Linear",
    "Load",
    "Measured",
    "Model",
    "Output",
    "PerfectlyPlastic",
    "Roll",
    "Segment",
    "Smooth",
    "SolverOptions",
    "Surface",
    "Sweep",
    "Swift",
    "Tabular",
    "Unload",
    "campaign_json_schema",
    "case_json_schema",
    "field_error",
    "identity_differences",
    "unit_vector",
]
