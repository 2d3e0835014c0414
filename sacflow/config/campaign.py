"""Campaign files: a base case and sweep blocks of dotted case paths (``sacflow campaign``).

The models check a campaign file's own fields; :mod:`sacflow.campaign.expansion` expands the
sweeps over the base case and validates every case.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, model_validator

from sacflow.config.base import NAME_PATTERN, Model, field_error, finite_json

__all__ = ["Campaign", "Sweep", "campaign_json_schema"]


class Sweep(Model):
    """One sweep block: the ``product`` of its parameter lists, or their ``zip``.

    Keys are dotted case paths with the ``--set`` syntax (``"load_path.0.to"``,
    ``"grid.nx"``); values are lists of values for that field.
    """

    mode: Literal["product", "zip"] = Field(
        description='"product": every combination of the lists; "zip": the lists side by side'
    )
    parameters: dict[str, Annotated[tuple[Any, ...], Field(min_length=1)]] = Field(
        min_length=1, description='dotted case paths -> lists of values, e.g. "grid.nx" = [32, 48]'
    )

    @model_validator(mode="after")
    def _check_parameters(self) -> Sweep:
        for key in self.parameters:
            keys = key.split(".")
            if not all(k and k == k.strip() for k in keys):
                raise field_error(
                    "parameters", f'"{key}" is not a dotted path like "grid.nx" or "load_path.0.to"'
                )
        sizes = {key: len(values) for key, values in self.parameters.items()}
        if self.mode == "zip" and len(set(sizes.values())) > 1:
            got = ", ".join(f"{key}: {n}" for key, n in sizes.items())
            raise field_error(
                "parameters",
                f"zip needs lists of equal length (got {got}); make them equal "
                'or use mode = "product"',
            )
        return self


class Campaign(Model):
    """A parametric study: a base case and sweep blocks, combined as a product of blocks."""

    name: str = Field(
        pattern=NAME_PATTERN,
        description="campaign name: letters, digits, '-', '_', '.' (prefix of the case names)",
    )
    description: str = Field("", description="free text")
    base: str | dict[str, Any] = Field(
        description="base case: an inline table [base], or a case file path relative to "
        "the campaign file"
    )
    sweep: tuple[Sweep, ...] = Field(
        min_length=1, description="sweep blocks ([[sweep]]), combined as a product of blocks"
    )

    @model_validator(mode="after")
    def _check_sweep(self) -> Campaign:
        seen: list[tuple[int, str]] = []
        for index, block in enumerate(self.sweep):
            for key in block.parameters:
                if key.split(".")[0] == "name":
                    raise field_error(
                        f"sweep.{index}.parameters",
                        '"name" cannot be swept: each case is named from the campaign name '
                        "and its parameters",
                    )
                for other_index, other in seen:
                    if _overlap(key, other):
                        raise field_error(
                            f"sweep.{index}.parameters",
                            f'"{key}" overlaps "{other}" of sweep.{other_index}; '
                            "sweep each field in one place",
                        )
                seen.append((index, key))
        return self


def _overlap(a: str, b: str) -> bool:
    """Tell whether one dotted path is the other or contains it (``grid`` and ``grid.nx``)."""
    ka, kb = a.split("."), b.split(".")
    n = min(len(ka), len(kb))
    return ka[:n] == kb[:n]


def campaign_json_schema() -> dict[str, Any]:
    """Return the JSON schema of :class:`Campaign`, strictly valid JSON (no bare Infinity)."""
    return finite_json(Campaign.model_json_schema())
