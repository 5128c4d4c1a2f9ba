"""A thin cyclonedds transport for the Unitree low-level topics ``rt/lowcmd``/``rt/lowstate``.

One ``DdsChannel`` per process and DDS domain: it pins the domain to one network interface
(loopback ``lo`` by default, the robot's Ethernet port on hardware) and hands out typed
publishers and subscribers. A subscriber keeps the newest sample with its arrival time;
``latest()`` never blocks, ``wait_for(timeout_s)`` blocks for the next one.

Needs cyclonedds 11 (optional extra ``deploy``). It does not talk to cyclonedds 0.10, which
the robot's own stack uses; bridge or match versions on hardware.
"""

from __future__ import annotations

import socket
import threading
import time
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from hybrid_recovery.deploy.protocol.messages import LowCmd_, LowState_

LOW_CMD_TOPIC = "rt/lowcmd"
LOW_STATE_TOPIC = "rt/lowstate"
TOPIC_TYPES: dict[str, type] = {LOW_CMD_TOPIC: LowCmd_, LOW_STATE_TOPIC: LowState_}
"""Message type of each low-level topic."""

MISSING_CYCLONEDDS = (
    "cyclonedds is required for the DDS transport: pip install 'hybrid_recovery[deploy]'"
)

T = TypeVar("T")
_DOMAINS: dict[int, tuple[str, Any]] = {}  # domain id -> (interface, cyclonedds Domain)
_DOMAINS_LOCK = threading.Lock()


def _cyclonedds() -> Any:
    """Import cyclonedds, or raise an ImportError saying how to install it."""
    try:
        import cyclonedds.core
        import cyclonedds.domain
        import cyclonedds.pub
        import cyclonedds.qos
        import cyclonedds.sub
        import cyclonedds.topic
    except ImportError as exc:
        raise ImportError(MISSING_CYCLONEDDS) from exc
    return cyclonedds


def cyclonedds_config(interface: str = "lo") -> str:
    """The cyclonedds XML configuration that binds a domain to one network interface."""
    return (
        '<CycloneDDS><Domain id="any"><General><Interfaces>'
        f'<NetworkInterface name="{interface}"/>'
        "</Interfaces></General></Domain></CycloneDDS>"
    )


def check_interface(interface: str) -> None:
    """Refuses a network interface this machine does not have, before cyclonedds logs
    its own complaint and fails with a bare ``DDSException``.

    Raises:
        ValueError: ``unknown network interface 'eth9' for DDS: this machine has ['lo',
            'eth0']``.
    """
    names = [name for _, name in socket.if_nameindex()]
    if interface not in names:
        raise ValueError(f"unknown network interface {interface!r} for DDS: this machine "
                         f"has {names}")


def _domain(domain_id: int, interface: str) -> None:
    """Create the process-wide cyclonedds Domain for ``domain_id`` once, on ``interface``.

    Raises:
        ValueError: the domain is bound to another interface in this process, the
            interface does not exist, or cyclonedds cannot open the domain on it (the
            message names the domain and the interface).
    """
    dds = _cyclonedds()
    with _DOMAINS_LOCK:
        if domain_id in _DOMAINS:
            bound = _DOMAINS[domain_id][0]
            if bound != interface:
                raise ValueError(
                    f"DDS domain {domain_id} is already bound to interface {bound!r} "
                    f"in this process, not {interface!r}"
                )
            return
        check_interface(interface)
        try:
            domain = dds.domain.Domain(domain_id, cyclonedds_config(interface))
        except dds.core.DDSException as err:
            raise ValueError(f"cannot open DDS domain {domain_id} on network interface "
                             f"{interface!r}: {err}") from err
        _DOMAINS[domain_id] = (interface, domain)


@dataclass(frozen=True)
class Received(Generic[T]):
    """A received sample.

    Attributes:
        msg: The message.
        t_receive: Arrival time, ``time.monotonic()`` seconds.
        count: How many samples the subscriber had received, this one included.
    """

    msg: T
    t_receive: float
    count: int


class DdsPublisher(Generic[T]):
    """Writes messages of one type on one topic (reliable, keep-last 1, as Unitree's SDK)."""

    def __init__(self, participant: Any, topic: Any) -> None:
        self._writer = _cyclonedds().pub.DataWriter(participant, topic)

    def write(self, msg: T) -> None:
        """Publish ``msg`` as is (set its CRC first with ``crc.with_crc``)."""
        self._writer.write(msg)


class DdsSubscriber(Generic[T]):
    """Keeps the newest sample of one topic, stamped with its arrival time."""

    def __init__(self, participant: Any, topic: Any, depth: int = 1) -> None:
        dds = _cyclonedds()
        policy = dds.qos.Policy
        qos = dds.qos.Qos(policy.Reliability.BestEffort, policy.History.KeepLast(depth))
        self._cond = threading.Condition()
        self._latest: Received[T] | None = None
        self._count = 0
        listener = dds.core.Listener(on_data_available=self._on_data_available)
        self._reader = dds.sub.DataReader(participant, topic, qos=qos, listener=listener)

    def _on_data_available(self, reader: Any) -> None:
        """Runs on cyclonedds' receive thread: keep the newest valid sample."""
        samples = reader.take(N=64)
        t_receive = time.monotonic()
        valid = [s for s in samples if getattr(s.sample_info, "valid_data", True)]
        if not valid:
            return
        with self._cond:
            self._count += len(valid)
            self._latest = Received(valid[-1], t_receive, self._count)
            self._cond.notify_all()

    @property
    def count(self) -> int:
        """Samples received so far."""
        return self._count

    def latest(self) -> Received[T] | None:
        """The newest sample, or None before the first; never blocks."""
        return self._latest

    def wait_for(self, timeout_s: float) -> Received[T] | None:
        """Block until a sample newer than the current one arrives; None after ``timeout_s``."""
        with self._cond:
            seen = self._count
            self._cond.wait_for(lambda: self._count > seen, timeout=timeout_s)
            return self._latest if self._count > seen else None


class DdsChannel:
    """DDS participant on one domain and network interface, with typed topic endpoints.

    Args:
        domain_id: DDS domain id, 0–232 (Unitree's robots use 0).
        interface: Network interface name, e.g. ``"lo"`` or the robot's ``"eth0"``.
    """

    def __init__(self, domain_id: int = 0, interface: str = "lo") -> None:
        if not 0 <= domain_id <= 232:
            raise ValueError(f"domain_id must be in [0, 232], got {domain_id}")
        dds = _cyclonedds()
        _domain(domain_id, interface)
        self.domain_id = domain_id
        self.interface = interface
        self._participant = dds.domain.DomainParticipant(domain_id)
        self._topics: dict[str, Any] = {}

    def _topic(self, name: str, msg_type: type | None) -> Any:
        if msg_type is None:
            if name not in TOPIC_TYPES:
                raise ValueError(f"unknown topic {name!r}: pass msg_type")
            msg_type = TOPIC_TYPES[name]
        if name not in self._topics:
            self._topics[name] = _cyclonedds().topic.Topic(self._participant, name, msg_type)
        return self._topics[name]

    def publisher(self, topic: str, msg_type: type | None = None) -> DdsPublisher:
        """A publisher on ``topic``; ``msg_type`` defaults from ``TOPIC_TYPES``."""
        return DdsPublisher(self._participant, self._topic(topic, msg_type))

    def subscriber(self, topic: str, msg_type: type | None = None, depth: int = 1) -> DdsSubscriber:
        """A subscriber on ``topic``; ``msg_type`` defaults from ``TOPIC_TYPES``."""
        return DdsSubscriber(self._participant, self._topic(topic, msg_type), depth)


def low_cmd_publisher(channel: DdsChannel) -> DdsPublisher[LowCmd_]:
    """Publisher of ``LowCmd_`` on ``rt/lowcmd`` (the controller side)."""
    return channel.publisher(LOW_CMD_TOPIC)


def low_state_subscriber(channel: DdsChannel) -> DdsSubscriber[LowState_]:
    """Subscriber to ``LowState_`` on ``rt/lowstate`` (the controller side)."""
    return channel.subscriber(LOW_STATE_TOPIC)


def low_state_publisher(channel: DdsChannel) -> DdsPublisher[LowState_]:
    """Publisher of ``LowState_`` on ``rt/lowstate`` (the robot or simulator side)."""
    return channel.publisher(LOW_STATE_TOPIC)


def low_cmd_subscriber(channel: DdsChannel) -> DdsSubscriber[LowCmd_]:
    """Subscriber to ``LowCmd_`` on ``rt/lowcmd`` (the robot or simulator side)."""
    return channel.subscriber(LOW_CMD_TOPIC)
