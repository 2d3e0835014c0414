"""The package's layout: layers that import one way, small modules, no private names across modules.

The layers, lowest first (``docs/architecture.md`` says what each holds and why):

0. ``sacflow.errors``, ``sacflow.lazy_exports``
1. ``sacflow.machine``: threads, allocator, environment, kernel cache, available memory
2. ``sacflow.kernels``: influence coefficients and FFT operators
3. ``sacflow.mechanics``: contact, hardening and return mapping, closed forms, fatigue, shakedown
4. ``sacflow.solver``: the incremental solver on plain parameters
5. ``sacflow.config``: the case schema (pydantic) and its messages
6. ``sacflow.storage``: every file read or written
7. ``sacflow.runner`` < 8. ``sacflow.compare`` < 9. ``sacflow.campaign`` < 10. ``sacflow.studies``
   < 11. ``sacflow.cli`` < 12. ``sacflow`` (the package's lazy public names)

A module may import its own layer and the layers below it, never one above: every import
statement of the package is read (inside functions and ``TYPE_CHECKING`` blocks too).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "sacflow"

LAYERS = {
    "sacflow.errors": 0,
    "sacflow.lazy_exports": 0,
    "sacflow.machine": 1,
    "sacflow.kernels": 2,
    "sacflow.mechanics": 3,
    "sacflow.solver": 4,
    "sacflow.config": 5,
    "sacflow.storage": 6,
    "sacflow.runner": 7,
    "sacflow.compare": 8,
    "sacflow.campaign": 9,
    "sacflow.studies": 10,
    "sacflow.cli": 11,
    "sacflow": 12,
}
#: Layers that compute on arrays: no pydantic, no configuration, no labelled or netCDF data.
NUMERICAL = ("sacflow.machine", "sacflow.kernels", "sacflow.mechanics", "sacflow.solver")
FORBIDDEN_IN_NUMERICAL = ("pydantic", "sacflow.config", "xarray", "netCDF4")
MAX_MODULE_LINES = 500
MAX_CLASS_LINES = 300


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def layer_of(module: str) -> tuple[str, int]:
    """The layer a dotted module name belongs to: the longest prefix in :data:`LAYERS`."""
    for prefix in sorted(LAYERS, key=len, reverse=True):
        if module == prefix or module.startswith(prefix + "."):
            return prefix, LAYERS[prefix]
    raise AssertionError(f"{module} is in no layer: add its package to LAYERS and the docs")


def imported_modules(tree: ast.AST, here: str, is_package: bool) -> list[tuple[str, int]]:
    """Every module an import statement names, with its line (relative imports resolved)."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = here.split(".")
                anchor = anchor if is_package else anchor[:-1]
                anchor = anchor[: len(anchor) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            found.append((base, node.lineno))
            # ``from sacflow.machine import kernel_cache`` imports a submodule
            found += [(f"{base}.{alias.name}", node.lineno) for alias in node.names]
    return found


SOURCES = sorted(PACKAGE.rglob("*.py"))


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_run_down_the_layers(path):
    here = module_name(path)
    own, rank = layer_of(here)
    tree = ast.parse(path.read_text(), str(path))
    wrong = []
    for target, line in imported_modules(tree, here, path.name == "__init__.py"):
        if target != "sacflow" and not target.startswith("sacflow."):
            continue
        if target == "sacflow":
            continue  # ``from sacflow import x``: x is checked as sacflow.x
        layer, target_rank = layer_of(target)
        if target_rank > rank:
            wrong.append(f"line {line}: {target} (layer {layer}, above {own})")
    assert not wrong, f"{here} imports upwards:\n" + "\n".join(wrong)


@pytest.mark.parametrize("path", [p for p in SOURCES if module_name(p).startswith(NUMERICAL)],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_numerical_layers_import_no_configuration_or_io_library(path):
    tree = ast.parse(path.read_text(), str(path))
    here = module_name(path)
    bad = [f"line {line}: {target}"
           for target, line in imported_modules(tree, here, path.name == "__init__.py")
           if any(target == f or target.startswith(f + ".") for f in FORBIDDEN_IN_NUMERICAL)]
    assert not bad, f"{here} (a numerical layer) imports:\n" + "\n".join(bad)


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_modules_and_classes_are_small(path):
    text = path.read_text()
    lines = text.count("\n") + (not text.endswith("\n"))
    assert lines <= MAX_MODULE_LINES, f"{path.name}: {lines} lines > {MAX_MODULE_LINES}"
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.ClassDef):
            size = node.end_lineno - node.lineno + 1
            assert size <= MAX_CLASS_LINES, f"class {node.name}: {size} lines"


def private_names_used_across_modules(path: Path) -> list[str]:
    """``from sacflow.x import _y`` and ``alias._y`` where ``alias`` is a sacflow module."""
    tree = ast.parse(path.read_text(), str(path))
    aliases: dict[str, str] = {}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("sacflow"):
                    aliases[a.asname or a.name.split(".")[0]] = a.name
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("sacflow"):
            for a in node.names:
                if a.name.startswith("_") and not a.name.startswith("__"):
                    found.append(f"line {node.lineno}: from {node.module} import {a.name}")
                aliases.setdefault(a.asname or a.name, f"{node.module}.{a.name}")
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and node.attr.startswith("_")
                and not node.attr.startswith("__") and isinstance(node.value, ast.Name)
                and node.value.id in aliases):
            found.append(f"line {node.lineno}: {node.value.id}.{node.attr}")
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            parts = node.value.split(".")
            if (node.value.startswith("sacflow.") and " " not in node.value
                    and any(p.startswith("_") and not p.startswith("__") for p in parts)):
                found.append(f"line {node.lineno}: {node.value!r}")
    return found


SCRIPTS = sorted([*PACKAGE.rglob("*.py"), *(ROOT / "tests").glob("*.py"),
                  *(ROOT / "pipelines").glob("*.py"), *(ROOT / "benchmarks").glob("*.py")])


@pytest.mark.parametrize("path", SCRIPTS, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_private_name_crosses_a_module(path):
    if path.name == "test_architecture.py":
        pytest.skip("this file names the rule's examples")
    found = private_names_used_across_modules(path)
    assert not found, f"{path.relative_to(ROOT)} uses private names of sacflow modules:\n" + (
        "\n".join(found))


def test_the_checks_catch_what_they_forbid(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import sacflow.solver.state as st\nfrom sacflow.storage.run_file import _x\n"
                   "st._private\n")
    assert len(private_names_used_across_modules(bad)) == 2
    tree = ast.parse("from sacflow.config.schema import Case\n")
    targets = [t for t, _ in imported_modules(tree, "sacflow.solver.layout", False)]
    assert layer_of(targets[0])[1] > LAYERS["sacflow.solver"]
    tree = ast.parse("from ..config import schema\n")
    targets = [t for t, _ in imported_modules(tree, "sacflow.solver.layout", False)]
    assert "sacflow.config.schema" in targets
