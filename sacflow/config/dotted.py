"""Dotted paths into nested case data (``"load_path.0.to"``): parsing, setting, flattening.

One rule for every dotted path sacflow reads or writes: ``--set`` overrides
(:func:`sacflow.config.parsing.apply_overrides`), campaign sweep keys (:mod:`sacflow.campaign`),
the run identity messages (:func:`sacflow.config.identity.identity_differences`) and the
campaign summary (:mod:`sacflow.compare.campaign`). Parts are separated by dots; a part of
ASCII digits only indexes a list from 0.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from typing import Any

from sacflow.errors import ConfigError

__all__ = ["cf_names", "flatten", "list_index", "set_dotted", "valid_indices"]

#: A list index in a dotted path: ASCII digits only (no sign).
INDEX = re.compile(r"[0-9]+")


#: A netCDF/CF variable name: a letter, then letters, digits and underscores (CF-1.10 §2.3).
CF_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def cf_names(keys: Iterable[str], taken: Iterable[str] = ()) -> dict[str, str]:
    """Map dotted paths to CF-valid variable names, deterministic and collision-free.

    ``"load_path.0.to"`` becomes ``load_path_0_to``: every character outside letters, digits
    and ``_`` becomes ``_``, a name not starting with a letter gets a ``p_`` prefix, and a name
    already used (by an earlier key or in ``taken``) gets ``_2``, ``_3``... appended.

    Parameters
    ----------
    keys : iterable of str
        Dotted paths (or any labels), in order.
    taken : iterable of str
        Names already in use in the same dataset.

    Returns
    -------
    dict
        Key -> CF name, in the order of ``keys``.
    """
    used = set(taken)
    out: dict[str, str] = {}
    for key in keys:
        name = re.sub(r"[^A-Za-z0-9_]", "_", key)
        if not CF_NAME.match(name):
            name = f"p_{name}"
        candidate, n = name, 1
        while candidate in used:
            n += 1
            candidate = f"{name}_{n}"
        used.add(candidate)
        out[key] = candidate
    return out


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


def list_index(key: str) -> int | None:
    """Return the list index a dotted-path part stands for (ASCII digits only), else None.

    Negative (``-1``), signed (``+1``), fractional (``1.5``) and non-ASCII digits (``²``) are
    not indices: a ``--set`` or sweep key counts items from the start, like the error messages.
    """
    return int(key) if INDEX.fullmatch(key) else None


def valid_indices(size: int) -> str:
    """Say which indices of a list of ``size`` items are valid (for messages)."""
    if size == 0:
        return "it is empty: use index 0 to add a first item"
    last = "0" if size == 1 else f"0..{size - 1}"
    item = "item" if size == 1 else "items"
    return f"it has {size} {item}: use index {last}, or {size} to add an item at the end"


def set_dotted(data: dict[str, Any], keys: list[str], value: Any, item: str) -> None:
    """Set ``data[keys[0]][keys[1]]... = value`` in place, creating missing tables.

    A whole-number key indexes a list (the index just past the end appends an item).

    Parameters
    ----------
    data : dict
        Nested case data, changed in place.
    keys : list of str
        The parts of the dotted path.
    value : Any
        The value to store.
    item : str
        What the user wrote (``grid.nx=64``), quoted in the messages.

    Raises
    ------
    ConfigError
        ``--set 'item': ...``: a bad list index, or a path through a value.
    """
    node: Any = data
    for depth, key in enumerate(keys):
        where = ".".join(keys[:depth]) or "the case"
        last = depth == len(keys) - 1
        if isinstance(node, list):
            key_or_index: Any = _list_position(key, len(node), where, item)
            if key_or_index == len(node):
                node.append({})
        elif isinstance(node, dict):
            key_or_index = key
            if not last and key not in node:
                node[key] = {}
        else:
            raise ConfigError(f"--set {item!r}: {where} is a value, not a table or list")
        if last:
            node[key_or_index] = value
        else:
            node = node[key_or_index]


def _list_position(key: str, size: int, where: str, item: str) -> int:
    """Return the index ``key`` into the list ``where`` of ``size`` items (may append)."""
    index = list_index(key)
    if index is None:
        raise ConfigError(
            f"--set {item!r}: {key!r} is not a list index ({where} is a list, indexed by whole "
            f"numbers from 0; negative indices are not supported); {valid_indices(size)}"
        )
    if index > size:
        raise ConfigError(
            f"--set {item!r}: index {index} is out of range for {where}; {valid_indices(size)}"
        )
    return index
