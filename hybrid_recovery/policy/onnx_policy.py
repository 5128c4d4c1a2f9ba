"""An exported policy on onnxruntime: o_t (87,) → a_t (27,), the one loader of every runner.

``policy.onnx`` (``input obs [1, 87]`` → ``actions [1, 27]``, the observation normaliser
inside the graph) is checked against this version's observation width when it is
loaded, and against ``policy.json`` next to it when that is present (or required).
The output is the raw network action a_t; :func:`hybrid_recovery.policy.joint_targets`
turns it into joint targets.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from hybrid_recovery.observation import ACTOR_OBS_DIM
from hybrid_recovery.policy.description import load_policy_description
from hybrid_recovery.robot.action import TARGET_RANGE_FACTOR
from hybrid_recovery.robot.constants import NUM_JOINTS

DESCRIPTION = "policy.json"
"""File name of the description next to the network."""


def _onnxruntime_reason(err: Exception) -> str:
    """onnxruntime's error without its prefix and the path it repeats:
    ``INVALID_PROTOBUF: Protobuf parsing failed.``"""
    text = str(err).strip()
    found = re.match(r"\[ONNXRuntimeError\] : \d+ : (\w+) : (.*)", text, re.S)
    if found is None:
        return f"{type(err).__name__}: {text}"
    code, detail = found.groups()
    return f"{code}: {detail.rsplit('failed:', 1)[-1].strip()}"


class OnnxPolicy:
    """A policy graph with one input [N, 87] (the actor observation), the actions first.

    Args:
        path: A ``.onnx`` file (external weights next to it, e.g. ``*.onnx.data``, load
            too), or a directory holding ``policy.onnx``.
        threads: onnxruntime intra-op threads (1 keeps a control loop's timing predictable).
        require_description: Refuse a network without ``policy.json`` next to it.

    Attributes:
        path: The ``.onnx`` file.
        description: ``policy.json``'s content (checked), or None when there is none.
        action_scale: s of q_ref = q* + s · a [rad] from the description, else None.
        target_range_factor: the joint ranges scaled about their middle by this bounded
            q_ref in training: the description's, else :data:`TARGET_RANGE_FACTOR`
            (descriptions written before it was recorded; those runs used it).

    Raises:
        FileNotFoundError: No network, or no description where one is required.
        ValueError: The description does not match this robot or version
            (:func:`load_policy_description`), onnxruntime cannot load the file (damaged,
            not ONNX, or its external weights missing; the message names the file), the
            graph does not take one input of 87 features, or, with a description, does
            not declare 27 actions.
    """

    def __init__(self, path: str | Path, threads: int = 1,
                 require_description: bool = False) -> None:
        import onnxruntime as ort

        path = Path(path)
        self.path = path / "policy.onnx" if path.is_dir() else path
        described = self.path.with_name(DESCRIPTION)
        self.description: dict | None = None
        if require_description or described.is_file():
            self.description = load_policy_description(described)
        self.action_scale: float | None = (None if self.description is None
                                           else float(self.description["action"]["scale"]))
        self.target_range_factor = float((self.description or {}).get("action", {}).get(
            "target_range_factor", TARGET_RANGE_FACTOR))
        if not self.path.is_file():
            raise FileNotFoundError(f"ONNX policy not found: {self.path}")
        options = ort.SessionOptions()
        options.intra_op_num_threads = threads
        options.inter_op_num_threads = 1
        options.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
        try:
            self.session = ort.InferenceSession(str(self.path), options,
                                                providers=["CPUExecutionProvider"])
        except Exception as err:  # noqa: BLE001 - onnxruntime's own exception types
            raise ValueError(f"ONNX policy {self.path} is damaged or unreadable "
                             f"({_onnxruntime_reason(err)})") from err
        inputs, outputs = self.session.get_inputs(), self.session.get_outputs()
        if len(inputs) != 1 or not inputs[0].shape or inputs[0].shape[-1] != ACTOR_OBS_DIM:
            raise ValueError(f"{self.path.name} takes {[i.shape for i in inputs]}, expected one "
                             f"input [1, {ACTOR_OBS_DIM}]")
        if self.description is not None and (not outputs[0].shape
                                             or outputs[0].shape[-1] != NUM_JOINTS):
            raise ValueError(f"{self.path.name} returns {outputs[0].shape}, expected "
                             f"[1, {NUM_JOINTS}]")
        self._input, self._output = inputs[0].name, outputs[0].name
        self._one_row = inputs[0].shape[0] == 1  # a graph exported for a batch of one

    def act(self, observations: np.ndarray) -> np.ndarray:
        """a = π(o) for a batch.

        Args:
            observations: o, shape (N, 87).

        Returns:
            a, shape (N, 27), float64 (unclipped, unscaled).

        Raises:
            ValueError: Wrong observation shape, or the graph returns a wrong shape.
        """
        obs = np.asarray(observations, dtype=np.float32)
        if obs.ndim != 2 or obs.shape[1] != ACTOR_OBS_DIM:
            raise ValueError(f"observations must have shape (N, {ACTOR_OBS_DIM}), "
                             f"got {obs.shape}")
        batches = [obs[i:i + 1] for i in range(len(obs))] if self._one_row else [obs]
        out = [self.session.run([self._output], {self._input: b})[0] for b in batches]
        action = np.concatenate(out).astype(float).reshape(len(obs), -1)
        if action.shape[1] != NUM_JOINTS:
            raise ValueError(f"ONNX policy returned {action.shape[1]} actions, "
                             f"expected {NUM_JOINTS}")
        return action

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        """a_t = π(o_t).

        Args:
            observation: o_t, shape (87,).

        Returns:
            a_t, shape (27,), float64 (unclipped, unscaled).

        Raises:
            ValueError: Wrong observation shape, or the graph returns a wrong shape.
        """
        obs = np.asarray(observation)
        if obs.shape != (ACTOR_OBS_DIM,):
            raise ValueError(f"observation must have shape ({ACTOR_OBS_DIM},), got {obs.shape}")
        return self.act(obs[None])[0]
