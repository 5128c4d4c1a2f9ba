"""The low-level topics over DDS as raw wire bytes: the fast path for 500 Hz states.

:class:`~hybrid_recovery.deploy.protocol.DdsChannel` publishes message objects, which
cyclonedds 11 serialises in Python at ≈ 1.3 ms per ``LowState_`` here. A :class:`FastLink`
writes and takes the serialised bytes themselves (encoded by :mod:`.wire`, ≈ 60 µs) through
the binding's C layer (``cyclonedds._clayer.ddspy_write``/``ddspy_take``). Those two
functions are private to cyclonedds-python, so :func:`check_wire_format` compares our
bytes with the binding's own serialiser once per process and refuses to run on a
mismatch. Topic types, names and QoS are those of the protocol package, so a peer using
``DdsChannel`` (or Unitree's SDK on the same cyclonedds) sees ordinary samples.
"""

from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from hybrid_recovery.deploy.protocol import (
    LOW_CMD_TOPIC,
    LOW_STATE_TOPIC,
    LowCmd_,
    LowState_,
    default_low_state,
    with_crc,
)
from hybrid_recovery.deploy.protocol import DdsChannel as _DdsChannel
from hybrid_recovery.deploy.robot_io import JointCommand, low_cmd_from_command
from hybrid_recovery.deploy.wire import encode_low_cmd, encode_low_state

_CHECKED = False


@dataclass(frozen=True)
class RawSample:
    """A received message as wire bytes.

    Attributes:
        wire: The serialised message, encapsulation header included.
        t_receive: Arrival time, ``time.monotonic()`` [s].
        count: Samples received so far, this one included.
    """

    wire: bytes
    t_receive: float
    count: int


def check_wire_format() -> None:
    """Raise RuntimeError unless :mod:`.wire` writes exactly what cyclonedds writes."""
    global _CHECKED
    if _CHECKED:
        return
    rng = np.random.default_rng(1)
    q, dq, tau = rng.normal(size=(3, 27)).astype(np.float32)
    cmd = JointCommand(q=q, kp=np.abs(dq), kd=np.abs(tau))
    if encode_low_cmd(cmd, 3) != low_cmd_from_command(cmd, 3).serialize(use_version_2=False):
        raise RuntimeError("hybrid_recovery.deploy.wire LowCmd_ bytes differ from cyclonedds'")
    state = default_low_state()
    state.tick, state.mode_machine = 7, 3
    state.imu_state.quaternion = [1.0, 0.0, 0.0, 0.0]
    for i in range(27):
        m = state.motor_state[i]
        m.mode, m.q, m.dq, m.tau_est = 1, float(q[i]), float(dq[i]), float(tau[i])
    ours = encode_low_state(7, np.array([1.0, 0, 0, 0]), np.zeros(3), q, dq, tau,
                            mode_machine=3)
    if ours != with_crc(state).serialize(use_version_2=False):
        raise RuntimeError("hybrid_recovery.deploy.wire LowState_ bytes differ from cyclonedds'")
    _CHECKED = True


def _dds() -> Any:
    import cyclonedds.core
    import cyclonedds.domain
    import cyclonedds.pub
    import cyclonedds.qos
    import cyclonedds.sub
    import cyclonedds.topic
    from cyclonedds import _clayer

    return cyclonedds, _clayer


class FastLink:
    """One side of the robot link on a DDS domain: writes one topic, keeps the newest of
    the other, both as wire bytes.

    Its writer carries ``hybrid-recovery <side> pid <pid>`` as DDS user data, and it
    watches its own topic for other writers (:meth:`other_writers`, :meth:`other_writes`):
    two controllers on one robot would both command it.

    Args:
        domain_id: DDS domain id (the robot uses 0).
        interface: Network interface, ``"lo"`` for a simulated robot.
        side: ``"controller"`` writes ``rt/lowcmd`` and reads ``rt/lowstate``; ``"robot"``
            the other way round.
    """

    def __init__(self, domain_id: int, interface: str,
                 side: Literal["controller", "robot"]) -> None:
        if side not in ("controller", "robot"):
            raise ValueError(f"side must be 'controller' or 'robot', got {side!r}")
        check_wire_format()
        self.channel = _DdsChannel(domain_id, interface)  # validates and binds the domain
        dds, self._clayer = _dds()
        self._participant = dds.domain.DomainParticipant(domain_id)
        out_name, in_name = ((LOW_CMD_TOPIC, LOW_STATE_TOPIC) if side == "controller"
                             else (LOW_STATE_TOPIC, LOW_CMD_TOPIC))
        types = {LOW_CMD_TOPIC: LowCmd_, LOW_STATE_TOPIC: LowState_}
        out_topic = dds.topic.Topic(self._participant, out_name, types[out_name])
        in_topic = dds.topic.Topic(self._participant, in_name, types[in_name])
        policy = dds.qos.Policy
        self.name = f"hybrid-recovery {side} pid {os.getpid()}"
        """How other processes see this link's writer (its DDS user data)."""
        self._writer = dds.pub.DataWriter(self._participant, out_topic, qos=dds.qos.Qos(
            policy.Userdata(self.name.encode())))
        if self._writer._use_version_2:
            raise RuntimeError("the DataWriter negotiated XCDR2; FastLink writes XCDR1")
        qos = dds.qos.Qos(policy.Reliability.BestEffort, policy.History.KeepLast(1))
        core = dds.core
        self._mask = core.SampleState.Any | core.ViewState.Any | core.InstanceState.Any
        self._userdata = policy.Userdata
        self.out_topic = out_name
        """The topic this side writes."""
        self._watch = dds.sub.DataReader(self._participant, out_topic, qos=dds.qos.Qos(
            policy.Reliability.BestEffort, policy.History.KeepLast(8),
            policy.IgnoreLocal.Participant))
        self._cond = threading.Condition()
        self._latest: RawSample | None = None
        self._count = 0
        listener = core.Listener(on_data_available=self._on_data_available)
        self._reader = dds.sub.DataReader(self._participant, in_topic, qos=qos,
                                          listener=listener)

    def _on_data_available(self, reader: Any) -> None:
        """cyclonedds' receive thread: keep the newest valid sample's bytes."""
        taken = self._clayer.ddspy_take(reader._ref, self._mask, 64)
        t_receive = time.monotonic()
        if isinstance(taken, int):
            return
        valid = [data for data, info in taken if info.valid_data]
        if not valid:
            return
        with self._cond:
            self._count += len(valid)
            self._latest = RawSample(valid[-1], t_receive, self._count)
            self._cond.notify_all()

    def write(self, wire: bytes) -> None:
        """Publish a serialised message (from :mod:`.wire`)."""
        ret = self._clayer.ddspy_write(self._writer._ref, wire)
        if ret < 0:
            raise RuntimeError(f"DDS write failed with code {ret}")

    def other_writers(self) -> list[str]:
        """The other writers of this side's topic that DDS has matched (this link's own
        excluded), each as its user data says (``hybrid-recovery controller pid 4242``)
        or, for a writer without it (another program), its participant's GUID."""
        found = []
        for handle in self._watch.get_matched_publications():
            data = self._watch.get_matched_publication_data(handle)
            if data is not None:
                found.append(self._describe(data))
        return found

    def other_writes(self) -> list[str]:
        """The writers (as :meth:`other_writers` names them) of samples another writer
        published on this side's topic since the last call; never blocks."""
        taken = self._clayer.ddspy_take(self._watch._ref, self._mask, 64)
        if isinstance(taken, int):
            return []
        handles = sorted({info.publication_handle for _, info in taken if info.valid_data})
        found = []
        for handle in handles:
            data = self._watch.get_matched_publication_data(handle)
            found.append(f"writer {handle}" if data is None else self._describe(data))
        return found

    def _describe(self, data: Any) -> str:
        userdata = self._userdata
        raw = data.qos[userdata].data if userdata in data.qos else b""
        text = bytes(raw).decode(errors="replace").strip()
        return text or f"participant {data.participant_key}"

    @property
    def count(self) -> int:
        """Samples received so far."""
        return self._count

    def latest(self) -> RawSample | None:
        """The newest received sample, or None before the first; never blocks."""
        return self._latest

    def wait_for(self, timeout_s: float) -> RawSample | None:
        """Block until a sample newer than the current one arrives; None after timeout."""
        with self._cond:
            seen = self._count
            self._cond.wait_for(lambda: self._count > seen, timeout=timeout_s)
            return self._latest if self._count > seen else None
