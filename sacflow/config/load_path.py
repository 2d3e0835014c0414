"""The load path: segments that load, unload, hold or roll the counter-body (``[[load_path]]``).

Each segment is chosen by ``kind``; :func:`sacflow.solver.layout.plan_steps` turns them into the
steps of a run. The order rules (load first, loads rise, unloads fall) are case-level checks
(:mod:`sacflow.config.case_checks`).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, field_validator

from sacflow.config.base import (
    MAX_PASSES,
    FiniteFloat,
    Model,
    NonNegativeFloat,
    PositiveFloat,
    StepCount,
    unit_vector,
)

__all__ = ["Hold", "Load", "Roll", "Segment", "Unload"]


class Load(Model):
    """Raise the normal load to ``to`` in ``increments`` equal steps."""

    kind: Literal["load"] = "load"
    to: PositiveFloat = Field(description="normal load at the end of the segment [N]")
    increments: StepCount = Field(description="number of load increments")
    at: tuple[FiniteFloat, FiniteFloat] | None = Field(
        None,
        description="load position (x1, x2) in the body frame [m] for this segment; "
        "default: where the load already is (initially the origin)",
    )


class Unload(Model):
    """Lower the normal load to ``to`` (default: full unload)."""

    kind: Literal["unload"] = "unload"
    to: NonNegativeFloat = Field(0.0, description="normal load at the end of the segment [N]")
    increments: StepCount = Field(description="number of unload increments")


class Hold(Model):
    """Keep the load constant (re-converge the coupled problem)."""

    kind: Literal["hold"] = "hold"
    increments: StepCount = Field(1, description="number of hold steps")


class Roll(Model):
    """Move the load over the body at constant load."""

    kind: Literal["roll"] = "roll"
    distance: PositiveFloat = Field(description="rolled distance [m]")
    steps: StepCount = Field(description="number of rolling steps")
    direction: tuple[FiniteFloat, FiniteFloat] = Field(
        (1.0, 0.0), description="rolling direction (d1, d2) in the surface plane, normalised"
    )
    passes: Annotated[int, Field(ge=1, le=MAX_PASSES)] | None = Field(
        None, description="passes over the same track (default 1); each later pass starts as "
        "'between' says"
    )
    between: Literal["lift", "reverse"] | None = Field(
        None, description="between passes: 'lift' (default) unloads at the end, moves the "
        "counter-body back to the start and loads again; 'reverse' rolls back over the track"
    )
    lift_increments: StepCount | None = Field(
        None, description="increments of each unloading and reloading between lifted passes "
        "(default 2)"
    )

    @field_validator("direction")
    @classmethod
    def _normalise(cls, value: tuple[float, float]) -> tuple[float, float]:
        return unit_vector(value)

    @property
    def pass_count(self) -> int:
        """Number of passes (``passes``, default 1)."""
        return self.passes or 1


Segment = Annotated[Load | Unload | Hold | Roll, Field(discriminator="kind")]
