"""Reference page of the case format, generated from the schema (``sacflow schema --markdown``).

``docs/case-format.md`` is this module's output: one section per TOML table of a case (and of a
campaign file), one row per key with its type, default, constraints and description, and one
section per variant of a discriminated union (``body.hardening`` by ``law``, ``surface`` and
``load_path`` by ``kind``). Everything comes from the JSON schema pydantic makes of the models
of :mod:`sacflow.config.schema` (:func:`~sacflow.config.schema.case_json_schema`,
:func:`~sacflow.config.schema.campaign_json_schema`), so the page follows the models;
``tests/test_schema_doc.py`` fails when the committed page is out of date.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from typing import Any

__all__ = ["COMMAND", "case_format_markdown"]

#: The command that writes the page (quoted in it and in the test's message).
COMMAND = "sacflow schema --markdown > docs/case-format.md"
#: Enumerations longer than this are listed under constraints instead of as the type.
INLINE_ENUM = 6
#: JSON-schema scalar types as the TOML user writes them.
SCALARS = {"number": "float", "integer": "int", "string": "string", "boolean": "bool",
           "null": "none"}
#: JSON-schema bounds and how the page writes them.
BOUNDS = (("minimum", "≥"), ("exclusiveMinimum", ">"), ("maximum", "≤"),
          ("exclusiveMaximum", "<"))

_HEADER = f"""# Case file format

Reference of every table and key of a case file (TOML) and of a campaign file, generated from
the schema (the pydantic models of `sacflow/config/schema.py`) by

```
{COMMAND}
```

Do not edit this page by hand: change the models and run the command again (a test compares
the page with the models). Units are SI (m, Pa, N); x3 is depth, positive into the body. Keys
without a default are required. A table chosen by a key (`law`, `kind`) has one section per
choice. Any key can be overridden on the command line with `--set dotted.key=value`.
"""


def case_format_markdown() -> str:
    """Return the Markdown reference of the case and campaign formats (``docs/case-format.md``)."""
    from sacflow.config.schema import campaign_json_schema, case_json_schema

    lines = [_HEADER]
    lines += _document(case_json_schema(), "Case file")
    lines += _document(campaign_json_schema(), "Campaign file")
    return "\n".join(lines).rstrip() + "\n"


def _document(schema: dict[str, Any], title: str) -> list[str]:
    """Sections of one schema: its top-level keys, then every table below them."""
    defs = schema.get("$defs", {})
    lines = [f"## {title}", "", _prose(schema.get("description", "")), ""]
    lines += _table(schema, defs)
    seen: set[tuple[str, str]] = set()
    for heading, model in _sections(schema, "", defs, seen):
        lines += ["", f"### {heading}", "", _prose(model.get("description", "")), ""]
        lines += _table(model, defs)
    return lines + [""]


def _sections(model: dict[str, Any], prefix: str, defs: dict, seen: set
              ) -> Iterator[tuple[str, dict[str, Any]]]:
    """``(heading, model)`` of every table below ``model``, depth first, each path once."""
    for key, prop in model.get("properties", {}).items():
        path = f"{prefix}{key}"
        node, array = _unwrap(prop)
        brackets = ("[[", "]]") if array else ("[", "]")
        for name, choice in _models(node, defs):
            if (path, name) in seen:
                continue
            seen.add((path, name))
            sub = defs[name]
            heading = f"`{brackets[0]}{path}{brackets[1]}`"
            if choice is not None:
                heading += f" with `{choice[0]} = \"{choice[1]}\"`"
            yield heading, sub
            yield from _sections(sub, f"{path}.", defs, seen)


def _unwrap(prop: dict[str, Any]) -> tuple[dict[str, Any], bool]:
    """Return the non-null part of an optional, and the items of an array (with ``True``)."""
    if "anyOf" in prop:
        options = [p for p in prop["anyOf"] if p.get("type") != "null"]
        if len(options) == 1:
            prop = options[0]
    if prop.get("type") == "array" and isinstance(prop.get("items"), dict):
        return prop["items"], True
    return prop, False


def _ref(node: dict[str, Any]) -> str | None:
    ref = node.get("$ref")
    return ref.rsplit("/", 1)[-1] if ref else None


def _models(node: dict[str, Any], defs: dict) -> list[tuple[str, tuple[str, str] | None]]:
    """Models a node stands for: one ``$ref``, or the variants of a discriminated union."""
    ref = _ref(node)
    if ref:
        return [(ref, None)]
    if "discriminator" in node:
        return list(_variants(node, defs))
    return []


def _variants(node: dict[str, Any], defs: dict) -> list[tuple[str, tuple[str, str]]]:
    """Return the variants of a discriminated union: model name, (discriminator, value)."""
    key = node["discriminator"]["propertyName"]
    names = [option["$ref"].rsplit("/", 1)[-1] for option in node["oneOf"]]
    return [(name, (key, _const(defs[name], key))) for name in names]


def _const(model: dict[str, Any], key: str) -> str:
    """Return the value of the discriminator ``key`` of a union variant."""
    prop = model["properties"][key]
    return str(prop.get("const", (prop.get("enum") or [prop.get("default")])[0]))


def _table(model: dict[str, Any], defs: dict) -> list[str]:
    """Return the key table of one model."""
    required = set(model.get("required", ()))
    rows = ["| key | type | default | constraints | description |", "|---|---|---|---|---|"]
    for key, prop in model.get("properties", {}).items():
        default = "required" if key in required else _default(prop)
        rows.append("| " + " | ".join(_cell(text) for text in (
            f"`{key}`", _type(prop, defs), default, _constraints(prop),
            prop.get("description", ""))) + " |")
    return rows


def _type(prop: dict[str, Any], defs: dict) -> str:
    """Return the type of a key as a TOML user reads it."""
    if "anyOf" in prop:
        options = [p for p in prop["anyOf"] if p.get("type") != "null"]
        text = " or ".join(_type(p, defs) for p in options)
        return text + (" (optional)" if len(options) < len(prop["anyOf"]) else "")
    if _ref(prop):
        return "table"
    if "discriminator" in prop:
        key = prop["discriminator"]["propertyName"]
        values = " \\| ".join(f'"{value}"' for _, (_, value) in _variants(prop, defs))
        return f"table chosen by `{key}`: {values}"
    if "const" in prop:
        return json.dumps(prop["const"])
    if "enum" in prop:
        if len(prop["enum"]) > INLINE_ENUM:
            return "name"
        return " \\| ".join(json.dumps(value) for value in prop["enum"])
    kind = prop.get("type", "")
    if kind == "array":
        return _array_type(prop, defs)
    if kind == "object":
        value_type = prop.get("additionalProperties")
        return f"table of {_type(value_type, defs)}" if isinstance(value_type, dict) else "table"
    if kind == "string" and prop.get("format") == "path":
        return "path"
    return SCALARS.get(kind, "any")


def _array_type(prop: dict[str, Any], defs: dict) -> str:
    """Return the type of an array key: a fixed tuple, an array of tables or a list."""
    if "prefixItems" in prop:
        return "[" + ", ".join(_type(p, defs) for p in prop["prefixItems"]) + "]"
    items = prop.get("items", {})
    if _ref(items) or "discriminator" in items:
        return "array of tables"
    return f"list of {_type(items, defs)}"


def _constraints(prop: dict[str, Any], each: bool = False) -> str:
    """Bounds, lengths, patterns and long enumerations of a key (and of its items)."""
    parts = [f"{sign} {_number(prop[name])}" for name, sign in BOUNDS if name in prop]
    if "pattern" in prop:
        parts.append(f"matches `{prop['pattern']}`")
    if "enum" in prop and len(prop["enum"]) > INLINE_ENUM:
        parts.append("one of " + ", ".join(f"`{value}`" for value in prop["enum"]))
    if each and parts:
        parts = ["each " + ", ".join(parts)]
    low, high = prop.get("minItems"), prop.get("maxItems")
    if low is not None and low == high:
        pass  # fixed length: the type shows it
    elif low == 1 and high is None:
        parts.append("not empty")
    elif low is not None or high is not None:
        parts.append(" ".join(filter(None, (
            f"at least {low}" if low else "", f"at most {high}" if high is not None else "")))
            + " items")
    for key in ("minLength", "maxLength"):
        if key in prop:
            parts.append(f"{'at least' if key == 'minLength' else 'at most'} {prop[key]} "
                         "characters")
    nested = [_constraints(p, each) for p in prop.get("anyOf", ()) if p.get("type") != "null"]
    if prop.get("type") == "array":
        items = prop.get("prefixItems") or [prop.get("items", {})]
        nested += list(dict.fromkeys(_constraints(p, each=True) for p in items))
    return "; ".join(part for part in (*parts, *nested) if part)


def _default(prop: dict[str, Any]) -> str:
    """Return the default of an optional key."""
    if "default" not in prop:
        return "required"
    value = prop["default"]
    if value is None:
        return "none"
    if isinstance(value, dict):
        return "its defaults" if _ref(prop) or "discriminator" not in prop else (
            f"`{json.dumps(value)}`")
    if isinstance(value, str) and value in ("Infinity", "-Infinity"):
        return "`inf`" if value == "Infinity" else "`-inf`"
    if isinstance(value, list):
        return "`[" + ", ".join(_default({"default": v}).strip("`") for v in value) + "]`"
    if isinstance(value, float | int) and not isinstance(value, bool):
        return f"`{_number(value)}`"
    return f"`{json.dumps(value, ensure_ascii=False)}`"


def _number(value: float | int) -> str:
    """Write a bound or default as in TOML (``1e-10``, ``0.5``, ``8``)."""
    if isinstance(value, int):
        return str(value)
    if 1e-3 <= abs(value) < 1e6 or value == 0:
        return repr(value)
    return re.sub(r"e([+-])0*(\d)", lambda m: f"e{m[1].strip('+')}{m[2]}", f"{value:g}")


def _prose(text: str) -> str:
    """Render a model's docstring as one Markdown paragraph per paragraph (reST literals → code)."""
    paragraphs = [" ".join(p.split()) for p in text.strip().split("\n\n")]
    return "\n\n".join(re.sub(r"``([^`]+)``", r"`\1`", p) for p in paragraphs if p)


def _cell(text: str) -> str:
    """Text safe in a Markdown table cell (no bare ``|``, no line breaks)."""
    text = " ".join(str(text).split())
    return re.sub(r"(?<!\\)\|", r"\\|", text)
