"""Dotted paths into nested case data (``"load_path.0.to"``): the one flattening rule.

Used by the run identity messages (:func:`sacflow.schema.identity_differences`) and the campaign
summary (:mod:`sacflow.compare.campaign`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

__all__ = ["flatten"]


def flatten(value: Any, prefix: str = "") -> dict[str, Any]:
    """Nested dicts and lists as ``{"dotted.key.0": scalar}`` (list items by index)."""
    if isinstance(value, Mapping):
        items: Iterable[tuple[Any, Any]] = value.items()
    elif isinstance(value, list | tuple):
        items = enumerate(value)
    else:
        return {prefix: value}
    out: dict[str, Any] = {}
    for key, item in items:
        out.update(flatten(item, f"{prefix}.{key}" if prefix else str(key)))
    return out
