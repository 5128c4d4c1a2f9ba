"""An exported recovery policy run with onnxruntime: o_t (87,) → a_t (27,)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnxruntime as ort

from hybrid_recovery.observation import ACTOR_OBS_DIM
from hybrid_recovery.robot.constants import NUM_JOINTS


class OnnxPolicy:
    """A policy graph with one input [1, 87] (the actor observation) and the actions first.

    Args:
        path: ``.onnx`` file (external weights next to it, e.g. ``*.onnx.data``, load too).
        num_threads: onnxruntime intra-op threads.

    Raises:
        FileNotFoundError: No such file.
        ValueError: The graph's input does not take 87 features.
    """

    def __init__(self, path: str | Path, num_threads: int = 1) -> None:
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"ONNX policy not found: {path}")
        options = ort.SessionOptions()
        options.intra_op_num_threads = num_threads
        options.inter_op_num_threads = 1
        self.session = ort.InferenceSession(str(path), options,
                                            providers=["CPUExecutionProvider"])
        inp = self.session.get_inputs()[0]
        width = inp.shape[-1] if inp.shape else None
        if isinstance(width, int) and width != ACTOR_OBS_DIM:
            raise ValueError(f"ONNX policy input '{inp.name}' takes {width} features, "
                             f"expected {ACTOR_OBS_DIM}")
        self._input = inp.name
        self._output = self.session.get_outputs()[0].name

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        """a_t = π(o_t).

        Args:
            observation: o_t, shape (87,).

        Returns:
            a_t, shape (27,), float64 (unscaled).

        Raises:
            ValueError: Wrong observation shape, or the graph returns a wrong shape.
        """
        obs = np.asarray(observation, dtype=np.float32)
        if obs.shape != (ACTOR_OBS_DIM,):
            raise ValueError(f"observation must have shape ({ACTOR_OBS_DIM},), got {obs.shape}")
        (out,) = self.session.run([self._output], {self._input: obs[None]})
        action = np.asarray(out, dtype=float).reshape(-1)
        if action.shape != (NUM_JOINTS,):
            raise ValueError(f"ONNX policy returned {action.size} actions, expected {NUM_JOINTS}")
        return action
