"""Shared fixtures: the project's model and, where ../shared is present, the reference."""

from __future__ import annotations

import os
from pathlib import Path

import mujoco
import numpy as np
import pytest

SHARED_DIR = Path(os.environ.get("HYBRID_RECOVERY_SHARED",
                                 Path(__file__).resolve().parents[1].parent / "shared"))
"""``../shared`` next to the checkout, or ``$HYBRID_RECOVERY_SHARED``."""
REFERENCE_DIR = SHARED_DIR / "reference" / "unitree_h1_2"
REFERENCE_MJCF = REFERENCE_DIR / "h1_2_handless.xml"


def random_state(model: mujoco.MjModel, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A random (qpos, qvel): random base pose and velocity, joints inside their ranges."""
    qpos = np.zeros(model.nq)
    qpos[:3] = rng.normal(size=3)
    quat = rng.normal(size=4)
    qpos[3:7] = quat / np.linalg.norm(quat)
    rng_lo, rng_hi = model.jnt_range[1:, 0], model.jnt_range[1:, 1]
    qpos[7:] = rng.uniform(rng_lo, rng_hi)
    qvel = rng.normal(size=model.nv)
    return qpos, qvel


@pytest.fixture(scope="session")
def own_model():
    from hybrid_recovery.dynamics import RobotModel

    return RobotModel.h1_2()


@pytest.fixture(scope="session")
def reference_model():
    if not REFERENCE_MJCF.is_file():
        pytest.skip(f"reference model not found at {REFERENCE_MJCF} (../shared absent)")
    from hybrid_recovery.dynamics import RobotModel

    return RobotModel.from_mjcf(REFERENCE_MJCF)


@pytest.fixture(params=["own", "reference"])
def robot(request):
    return request.getfixturevalue(f"{request.param}_model")


@pytest.fixture
def dds_domain() -> int:
    """A random DDS domain id in [1, 200] that no other pytest-xdist worker can draw.

    Worker ``gw<i>`` of ``n`` draws only ids ≡ i + 1 (mod n), so loopback tests running at
    once in different workers never share a domain (a shared one would show each test the
    other's writers).
    """
    import random

    worker = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw"))
    workers = max(int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")), 1)
    return random.SystemRandom().choice(range(1 + worker % workers, 201, workers))
