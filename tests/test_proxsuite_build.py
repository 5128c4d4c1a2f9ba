"""The QPs run on proxsuite's portable build, and the model-based half reproduces bit for
bit from one process to the next (``hybrid_recovery.control.proxsuite_build``)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from hybrid_recovery.control import proxsuite_build, wbc_qp
from hybrid_recovery.getup import contact_qp, feasibility

_TRAJECTORY = """
import hashlib, mujoco, numpy as np
from hybrid_recovery.control.torque_model import CONTROL_DT
from hybrid_recovery.controllers.model import ModelController
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import eval_model, start_state
junk = [np.empty(n) for n in range({junk})]  # another heap layout per process
model = eval_model(None, CONTROL_DT, True, "default")
data = mujoco.MjData(model)
data.qpos[:] = start_state(Scenario("kneeling", seed=2), None, "default")
mujoco.mj_forward(model, data)
controller = ModelController()
controller.reset(model, data)
torques = []
for _ in range(1500):
    data.ctrl[:] = controller(model, data)
    torques.append(data.ctrl.copy())
    mujoco.mj_step(model, data)
print(controller.phase, hashlib.sha256(np.array(torques).tobytes()).hexdigest())
"""


def _run(code: str, hash_seed: int) -> str:
    env = {**os.environ, "PYTHONHASHSEED": str(hash_seed)}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout.strip().splitlines()[-1]


def test_every_qp_runs_on_the_portable_build():
    assert proxsuite_build.BUILD == proxsuite_build.PORTABLE_BUILD
    for module in (wbc_qp, contact_qp, feasibility):
        assert module.proxsuite is proxsuite_build.proxsuite
    assert type(proxsuite_build.proxsuite.proxqp.dense.QP(3, 0, 0)).__module__.startswith(
        f"proxsuite.{proxsuite_build.PORTABLE_BUILD}.")


def test_the_model_controller_reproduces_bit_for_bit_across_processes():
    """A kneeling start under ``--controller model`` for 3 s (the kneel move's bow and
    push-up on the multi-contact QP) in three processes with other hash seeds and heaps:
    on proxsuite's AVX2 / AVX-512 builds four such runs gave four trajectories."""
    runs = {_run(_TRAJECTORY.format(junk=junk), seed) for seed, junk in
            ((1, 3), (2, 40), (3, 517))}
    assert len(runs) == 1, runs


def test_loading_proxsuite_first_is_warned():
    code = ("import warnings, proxsuite\nfrom proxsuite import instructionset as i\n"
            "warnings.simplefilter('error', RuntimeWarning)\n"
            "try:\n    import hybrid_recovery.control.proxsuite_build as b\n"
            "    print('loaded', b.BUILD, i.has_AVX2())\n"
            "except RuntimeWarning as w:\n    print('warned', w)\n")
    out = _run(code, 0)
    if out.startswith("loaded proxsuite_pywrap False"):
        pytest.skip("a CPU without AVX2: proxsuite loads its portable build itself")
    assert out.startswith("warned proxsuite was loaded before hybrid_recovery's QPs with its "
                          "proxsuite_pywrap_avx"), out
