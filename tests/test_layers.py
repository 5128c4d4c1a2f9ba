"""Layers import downward only: every module's imports, parsed, against the layer order.

files / checks → robot → dynamics → observation → sim → policy → control / envs →
training / getup → controllers → evaluation / deploy → bench / demo / recipe → cli. A
package may import its own modules and any package of a lower layer; packages of one layer
do not import each other. Imports inside functions count too.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "hybrid_recovery"

LAYERS: tuple[tuple[str, ...], ...] = (
    ("files", "checks"),
    ("robot",),
    ("dynamics",),
    ("observation",),
    ("sim",),
    ("policy",),
    ("control", "envs"),
    ("training", "getup"),
    ("controllers",),
    ("evaluation", "deploy"),
    ("bench", "demo", "recipe"),
    ("cli",),
)
"""The layer order, lowest first."""

FORBIDDEN: dict[str, tuple[str, ...]] = {
    "envs": ("policy",),
    "deploy": ("envs", "training"),
    "controllers": ("training",),
}
"""Lower packages a package still must not import: the environment knows nothing of the
exported policy; the robot's runner loads neither the environment nor torch training;
the controllers know nothing of training (evaluation and deploy sit above them)."""

LEVEL = {pkg: i for i, layer in enumerate(LAYERS) for pkg in layer}


def imported_packages(source: str, module: str) -> set[str]:
    """The ``hybrid_recovery`` subpackages a module's source imports (any depth).

    Args:
        source: The module's Python source.
        module: Its dotted name, e.g. ``hybrid_recovery.envs.rewards`` (for relative
            imports).
    """
    found: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".")[: -node.level]
                names = [".".join([*base, node.module] if node.module else base)]
            else:
                names = [node.module or ""]
            if names == ["hybrid_recovery"]:
                names = [f"hybrid_recovery.{alias.name}" for alias in node.names]
        else:
            continue
        found |= {n.split(".")[1] for n in names
                  if n.startswith("hybrid_recovery.") and len(n.split(".")) > 1}
    return found


def violations(package: str, imported: set[str]) -> list[str]:
    """Why each import of ``package`` breaks the layer order (empty: none)."""
    out = []
    for other in sorted(imported - {package}):
        if other not in LEVEL:
            out.append(f"{package} imports {other}, which is in no layer")
        elif LEVEL[other] >= LEVEL[package]:
            out.append(f"{package} imports {other}, which is not below it")
        elif other in FORBIDDEN.get(package, ()):
            out.append(f"{package} must not import {other}")
    return out


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if len(parts) > 2:
            yield ".".join(parts), parts[1], path


def test_every_subpackage_is_in_a_layer():
    packages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    assert packages == set(LEVEL)


@pytest.mark.parametrize("module,package,path", list(_modules()),
                         ids=[m for m, _, _ in _modules()])
def test_module_imports_only_lower_layers(module, package, path):
    assert violations(package, imported_packages(path.read_text(), module)) == []


def test_the_checker_sees_upward_relative_and_function_level_imports():
    source = ("from hybrid_recovery.robot import constants\n"
              "def f():\n"
              "    from hybrid_recovery.training.export import export_policy\n"
              "from ..envs import RecoveryEnv\n"
              "from hybrid_recovery import policy\n")
    imported = imported_packages(source, "hybrid_recovery.deploy.bridge")
    assert imported == {"robot", "training", "envs", "policy"}
    assert violations("deploy", imported) == ["deploy must not import envs",
                                              "deploy must not import training"]
    assert violations("control", {"evaluation"}) == [
        "control imports evaluation, which is not below it"]
    assert violations("envs", {"control"}) == ["envs imports control, which is not below it"]
    assert violations("envs", {"policy"}) == ["envs must not import policy"]


def test_the_controllers_import_nothing_of_evaluation_deploy_or_training():
    imported = set()
    for module, package, path in _modules():
        if package == "controllers":
            imported |= imported_packages(path.read_text(), module)
    assert imported, "the controllers package was not found"
    assert not imported & {"evaluation", "deploy", "training"}
    assert violations("controllers", {"evaluation", "deploy", "training"}) == [
        "controllers imports deploy, which is not below it",
        "controllers imports evaluation, which is not below it",
        "controllers must not import training"]
