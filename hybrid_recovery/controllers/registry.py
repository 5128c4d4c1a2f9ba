"""One registry of controllers: :data:`CONTROLLERS` maps each name to its constructor.

A spec is ``NAME`` or ``NAME:PATH`` (``onnx:PATH``, ``hybrid:PATH``); :func:`make`
builds one. Every command that runs a controller (eval, compare, demo, play, sim2sim,
run-robot) takes ``--controller`` from here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from hybrid_recovery.controllers.hybrid import HybridController
from hybrid_recovery.controllers.model import ModelController
from hybrid_recovery.controllers.policy import OnnxPolicyController
from hybrid_recovery.controllers.protocol import Controller, OutputKind
from hybrid_recovery.controllers.qp import QpController
from hybrid_recovery.controllers.zero import ZeroController
from hybrid_recovery.policy import SHIPPED, resolve_policy


@dataclass(frozen=True)
class Registered:
    """A registry entry.

    Attributes:
        build: The constructor: (resolved policy path or None, output kind) → controller.
        outputs: The output kinds it can give, its default first.
        policy: Whether it runs an exported policy: ``"required"`` (``onnx:PATH``),
            ``"shipped"`` (the shipped one unless a path is given) or ``"none"``.
    """

    build: Callable[[Path | None, OutputKind], Controller]
    outputs: tuple[OutputKind, ...]
    policy: Literal["none", "shipped", "required"] = "none"


CONTROLLERS: dict[str, Registered] = {
    "zero": Registered(lambda path, output: ZeroController(), ("position",)),
    "learned": Registered(lambda path, output: OnnxPolicyController(_given(path)),
                          ("position",), "shipped"),
    "onnx": Registered(lambda path, output: OnnxPolicyController(_given(path)),
                       ("position",), "required"),
    "qp": Registered(lambda path, output: QpController(), ("torque",)),
    "model": Registered(lambda path, output: ModelController(), ("torque",)),
    "hybrid": Registered(lambda path, output: HybridController(_given(path), output=output),
                         ("position", "torque"), "shipped"),
}
"""Controller name → its entry: ``zero`` (PD at the default pose), ``learned`` (the shipped
policy), ``onnx:PATH`` (an exported policy), ``qp`` (the QP balance controller), ``model``
(the QP with its rise from a crouch, ground moves and push-up), ``hybrid[:PATH]`` (policy,
QP and ground moves)."""


def _given(path: Path | None) -> Path:
    assert path is not None  # make() resolves the policy of every entry that runs one
    return path


def known() -> str:
    """The registered names, as an error message lists them."""
    return ", ".join(sorted(CONTROLLERS))


def entry(spec: str) -> tuple[Registered, str]:
    """The entry of ``spec`` and the path part after ``NAME:`` ('' when none).

    Raises:
        ValueError: ``unknown controller 'nope': known controllers are hybrid, learned,
            model, onnx, qp, zero``; or a path given to a controller without a policy.
    """
    name, _, arg = spec.partition(":")
    if name not in CONTROLLERS:
        raise ValueError(f"unknown controller '{spec}': known controllers are {known()}")
    found = CONTROLLERS[name]
    if arg and found.policy == "none":
        raise ValueError(f"controller '{name}' takes no policy path, got '{spec}'")
    return found, arg


def policy_path(spec: str) -> Path | None:
    """The ``policy.onnx`` a controller spec runs; None for a controller without a policy,
    an unknown spec or a path that does not exist."""
    try:
        found, arg = entry(spec)
    except ValueError:
        return None
    if found.policy == "none" or (found.policy == "required" and not arg):
        return None
    try:
        path = resolve_policy(arg or SHIPPED)
    except FileNotFoundError:
        return None
    return path / "policy.onnx" if path.is_dir() else path


def make(spec: str, prefer: OutputKind | None = None) -> Controller:
    """Builds a controller from its spec (``zero``, ``learned``, ``onnx:PATH``, ``qp``,
    ``model``, ``hybrid[:PATH]``).

    Args:
        spec: ``NAME`` or ``NAME:PATH``.
        prefer: The output kind wanted where the controller offers it (the robot runner
            asks for ``"torque"``); None for its default.

    Raises:
        ValueError: an unknown name (the message lists the known ones), a missing or
            unresolvable policy path, or ``learned`` with no shipped policy.
    """
    found, arg = entry(spec)
    path = None
    if found.policy != "none":
        if found.policy == "required" and not arg:
            raise ValueError(f"controller '{spec}' needs a policy path: {spec}:PATH")
        try:
            path = resolve_policy(arg or SHIPPED)
        except FileNotFoundError as err:
            raise ValueError(str(err)) from err
    output = prefer if prefer in found.outputs else found.outputs[0]
    return found.build(path, output)
