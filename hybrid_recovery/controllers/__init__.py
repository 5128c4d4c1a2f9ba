"""Every controller of the robot behind one interface (:class:`Controller`) and one
registry (:data:`CONTROLLERS`, :func:`make`): ``zero``, ``learned``/``onnx:PATH``, ``qp``,
``model``, ``hybrid``. The building blocks live below: the QP and the supervisor in
``control``, the ground moves and the push-up in ``getup``.
"""

from hybrid_recovery.controllers.hybrid import HybridController
from hybrid_recovery.controllers.model import ModelController
from hybrid_recovery.controllers.policy import OnnxPolicyController
from hybrid_recovery.controllers.protocol import OUTPUT_KINDS, Controller, OutputKind
from hybrid_recovery.controllers.qp import QpController
from hybrid_recovery.controllers.registry import CONTROLLERS, make, policy_path
from hybrid_recovery.controllers.zero import ZeroController

__all__ = ["CONTROLLERS", "OUTPUT_KINDS", "Controller", "HybridController", "ModelController",
           "OnnxPolicyController", "OutputKind", "QpController", "ZeroController", "make",
           "policy_path"]
