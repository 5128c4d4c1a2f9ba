"""Hardware deployment: the Unitree low-level protocol, transport and runners.

* ``protocol``: ``LowCmd_``/``LowState_``, their CRC, the cyclonedds transport.
* ``robot_io``: joint ↔ motor-slot map, :class:`LowStateReading`, :class:`JointCommand`.
* ``wire`` / ``fast_dds``: the messages as DDS wire bytes (the fast 500 Hz path).
* ``state_machine``: the safety layer (pure logic, no I/O; its limits are
  :mod:`hybrid_recovery.robot.limits`).
* ``policy_runner``: the ONNX policy on the training observation builder.
* ``sim_robot`` / ``bridge``: a simulated H1-2 and the controller loop over DDS.
* ``sim2sim`` / ``balance_trace``: the policy in MuJoCo with a video and balance trace.
* ``timing``: loop timing (its benchmark is ``hybrid-recovery bench deploy``).

Nothing is imported here: ``protocol`` must stay importable without MuJoCo or torch.
"""
