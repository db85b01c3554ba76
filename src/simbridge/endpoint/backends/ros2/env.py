"""Where ROS 2 traffic may go: this machine only, unless the user says otherwise.

DDS discovers peers by multicast on every interface by default. Every ROS 2
process simbridge starts (the endpoint, test and benchmark nodes, demos) gets
`ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` and a Fast DDS profile whose transports
are UDP bound to 127.0.0.1 plus shared memory (with a segment big enough for
camera images), and runs in a ROS domain of its own choosing. A variable the
user has already set is kept: that is how one points the endpoint at a wider
ROS 2 graph. Importing this module does not need rclpy.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import ipaddress
import os
import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

from simbridge.errors import EndpointError

__all__ = [
    "DEFAULT_SHM_SEGMENT",
    "FASTDDS_PROFILE_VARS",
    "WRITER_ALLOCATED_SAMPLES",
    "WRITER_HEARTBEAT_NS",
    "WRITER_NACK_SUPPRESSION_NS",
    "apply_ros2_env",
    "clean_stale_shm",
    "fastdds_peers_profile_xml",
    "fastdds_profile_xml",
    "ros2_env",
    "ros2_python",
    "write_fastdds_profile",
]

DEFAULT_SHM_SEGMENT = 16 * 1024 * 1024
"""Shared-memory segment per participant; Fast DDS's 0.5 MiB default cannot hold an image."""

SHM_PORT_QUEUE = 4096
"""Messages a shared-memory port holds (Fast DDS: 512); bursts beyond it wait for
reliability's repair (a 3 s heartbeat), which stalls a fast publisher."""

WRITER_ALLOCATED_SAMPLES = 8192
"""Samples a publisher's history reserves room for up front (Fast DDS: 100), capped by its
depth: about 0.5 KiB each, so at most 4 MiB for a publisher this deep or deeper. Fast DDS
sizes each matched reader's list of unacknowledged samples from it and grows that list
one element at a time beyond it, copying it whole each time: a burst of thousands of
messages on a deep publisher (the endpoint relaying a sim's burst) spent an eighth of
its publish time in those copies."""

WRITER_HEARTBEAT_NS = 100_000_000
"""How often a reliable publisher with unacknowledged samples announces them (Fast DDS:
every 3 s). A subscriber that missed samples (it matched the publisher a moment after
the publisher matched it, or its shared-memory queue was full) asks for them again only
after a heartbeat, so the default stalls it for up to 3 s; the heartbeat stops once
every sample is acknowledged."""

WRITER_NACK_SUPPRESSION_NS = 10_000_000
"""How long a reliable publisher treats a sample it just sent as in flight (Fast DDS: 0).
At 0, every sample sent wakes Fast DDS's event thread to mark it sent: several
microseconds of CPU per message on a 2-core machine. A repair request for a sample this
recent is ignored; the next heartbeat brings it back."""

FASTDDS_PROFILE_VARS = ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE")
"""Fast DDS 2.x reads the first, 3.x the second; both are set to the same file."""

_PROFILE = """<?xml version="1.0" encoding="UTF-8" ?>
<!-- simbridge: DDS traffic on this machine only (UDP on 127.0.0.1 + shared memory). -->
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>simbridge_udp_loopback</transport_id>
        <type>UDPv4</type>
        <interfaceWhiteList>
          <address>127.0.0.1</address>
        </interfaceWhiteList>
      </transport_descriptor>
      <transport_descriptor>
        <transport_id>simbridge_shm</transport_id>
        <type>SHM</type>
        <segment_size>{segment}</segment_size>
        <port_queue_capacity>{queue}</port_queue_capacity>
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="simbridge_localhost" is_default_profile="true">
      <rtps>
        <userTransports>
          <transport_id>simbridge_shm</transport_id>
          <transport_id>simbridge_udp_loopback</transport_id>
        </userTransports>
        <useBuiltinTransports>false</useBuiltinTransports>
      </rtps>
    </participant>
    <data_writer profile_name="simbridge_writer" is_default_profile="true">
      <topic>
        <resourceLimitsQos>
          <allocated_samples>{allocated}</allocated_samples>
        </resourceLimitsQos>
      </topic>
      <times>
        <heartbeatPeriod>
          <sec>0</sec>
          <nanosec>{heartbeat_ns}</nanosec>
        </heartbeatPeriod>
        <nackSupressionDuration>
          <sec>0</sec>
          <nanosec>{nack_suppression_ns}</nanosec>
        </nackSupressionDuration>
      </times>
    </data_writer>
  </profiles>
</dds>
"""


def ros2_python() -> Path | None:
    """The ROS 2 venv's interpreter: $SIMBRIDGE_ROS2_PYTHON, else the checkout's .venv-ros2.

    None when neither exists (run `make ros2`).
    """
    given = os.environ.get("SIMBRIDGE_ROS2_PYTHON")
    if given:
        return Path(given) if Path(given).exists() else None
    path = Path(__file__).resolve().parents[5] / ".venv-ros2" / "bin" / "python"
    return path if path.exists() else None


def fastdds_profile_xml(shm_segment: int = DEFAULT_SHM_SEGMENT) -> str:
    """The Fast DDS XML profile: loopback UDP and shared memory, nothing else; publishers
    reserve room for bursts and repair missed samples soon (WRITER_*)."""
    return _PROFILE.format(
        segment=int(shm_segment),
        queue=SHM_PORT_QUEUE,
        allocated=WRITER_ALLOCATED_SAMPLES,
        heartbeat_ns=WRITER_HEARTBEAT_NS,
        nack_suppression_ns=WRITER_NACK_SUPPRESSION_NS,
    )


_PEERS_PROFILE = """<?xml version="1.0" encoding="UTF-8" ?>
<!-- simbridge: one host of a ROS 2 graph across hosts on a trusted network. UDP on
     {address} only, discovery by unicast to the listed peers, no multicast, no shared memory. -->
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>simbridge_udp_peers</transport_id>
        <type>UDPv4</type>
        <interfaceWhiteList>
          <address>{address}</address>
        </interfaceWhiteList>
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="simbridge_peers" is_default_profile="true">
      <rtps>
        <userTransports>
          <transport_id>simbridge_udp_peers</transport_id>
        </userTransports>
        <useBuiltinTransports>false</useBuiltinTransports>
        <builtin>
          <metatrafficUnicastLocatorList>
            <locator/>
          </metatrafficUnicastLocatorList>
          <initialPeersList>
{peers}
          </initialPeersList>
        </builtin>
      </rtps>
    </participant>
  </profiles>
</dds>
"""

_PEER = """            <locator>
              <udpv4>
                <address>{address}</address>
              </udpv4>
            </locator>"""


def fastdds_peers_profile_xml(address: str, peers: Sequence[str]) -> str:
    """A Fast DDS profile for one host of a graph spanning hosts: UDP on this host's IPv4
    `address` only, discovery by unicast to `peers` (every host's address, this one's
    included, so processes on one host find each other too), no multicast, no shared memory.

    Use it with ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET (docs/ros2.md: Several hosts on one
    ROS 2 graph); DDS discovery has no authentication, so only on a trusted network.
    """
    own = _ipv4(address, "address")
    if not peers:
        raise EndpointError("no peers given: a host needs at least one peer address to discover")
    checked = dict.fromkeys(_ipv4(p, "peer") for p in peers)
    return _PEERS_PROFILE.format(
        address=own, peers="\n".join(_PEER.format(address=p) for p in checked)
    )


def _ipv4(text: str, what: str) -> str:
    """`text` as a plain IPv4 address, or an error naming it."""
    try:
        return str(ipaddress.IPv4Address(text.strip()))
    except ValueError:
        raise EndpointError(f"{what} {text!r} is not an IPv4 address (like 10.0.0.2)") from None


def write_fastdds_profile(
    shm_segment: int = DEFAULT_SHM_SEGMENT, directory: Path | None = None
) -> Path:
    """Write the profile once (named by its content) and return its path."""
    text = fastdds_profile_xml(shm_segment)
    digest = hashlib.sha256(text.encode()).hexdigest()[:12]
    folder = directory if directory is not None else Path(tempfile.gettempdir())
    path = folder / f"simbridge-fastdds-{digest}.xml"
    if not path.exists() or path.read_text() != text:
        folder.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text)
        tmp.replace(path)
    return path


def ros2_env(
    base: Mapping[str, str] | None = None,
    *,
    domain_id: int | None = None,
    shm_segment: int = DEFAULT_SHM_SEGMENT,
) -> dict[str, str]:
    """The ROS 2 settings for a process: `base` (default os.environ) plus what it lacks.

    `domain_id`, when given, replaces any ROS_DOMAIN_ID (tests and benchmarks use
    their own); otherwise one already set is kept and 0 is the default.
    """
    env = dict(os.environ if base is None else base)
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    env.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    if domain_id is not None:
        env["ROS_DOMAIN_ID"] = str(domain_id)
    else:
        env.setdefault("ROS_DOMAIN_ID", "0")
    profile = next((env[v] for v in FASTDDS_PROFILE_VARS if env.get(v)), None)
    if profile is None:
        profile = str(write_fastdds_profile(shm_segment))
    for var in FASTDDS_PROFILE_VARS:
        env.setdefault(var, profile)
    return env


def apply_ros2_env(*, domain_id: int | None = None) -> dict[str, str]:
    """Set the ROS 2 settings in this process (before rclpy.init); returns what is used."""
    env = ros2_env(domain_id=domain_id)
    used = {
        key: env[key]
        for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "RMW_IMPLEMENTATION")
    }
    used["FASTDDS_PROFILE"] = env[FASTDDS_PROFILE_VARS[0]]
    for key in (*used, *FASTDDS_PROFILE_VARS):
        if key in env:
            os.environ[key] = env[key]
    return used


def clean_stale_shm(directory: Path = Path("/dev/shm"), min_age: float = 2.0) -> list[str]:
    """Remove Fast DDS shared-memory files whose owner is gone; returns their names.

    A live participant holds an flock on each `<name>_el` file (as `fastdds shm
    clean` relies on), so files of running processes, anyone's, are left alone; a port
    segment goes only when no process maps it.
    """
    removed: list[str] = []
    if not directory.is_dir():
        return removed
    now = time.time()
    for lock in directory.glob("fastrtps_*_el"):
        try:
            if now - lock.stat().st_mtime < min_age:
                continue
            fd = os.open(lock, os.O_RDWR)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            continue  # still owned
        try:
            base = lock.name[: -len("_el")]
            for name in (base, lock.name, f"sem.{base}_mutex"):
                with contextlib.suppress(FileNotFoundError):
                    (directory / name).unlink()
                    removed.append(name)
        finally:
            os.close(fd)
    removed += _clean_stale_ports(directory, now - min_age)
    return removed


def _clean_stale_ports(directory: Path, older_than: float) -> list[str]:
    """Remove this user's Fast DDS port segments (`fastrtps_port<N>` and their mutex) that
    no running process maps: ports have no lock file, and Fast DDS never deletes them."""
    mapped = _mapped_shm_files()
    removed: list[str] = []
    for port in directory.glob("fastrtps_port*"):
        if not port.name.removeprefix("fastrtps_port").isdigit():
            continue
        names = (port.name, f"sem.{port.name}_mutex")
        try:
            stat = port.stat()
        except FileNotFoundError:
            continue
        if stat.st_uid != os.getuid() or stat.st_mtime > older_than:
            continue
        if any(str(directory / name) in mapped for name in names):
            continue  # a live participant listens on it
        for name in names:
            with contextlib.suppress(FileNotFoundError):
                (directory / name).unlink()
                removed.append(name)
    return removed


def _mapped_shm_files() -> set[str]:
    """Paths of /dev/shm files mapped by any process whose maps this user can read."""
    mapped: set[str] = set()
    for maps in Path("/proc").glob("[0-9]*/maps"):
        try:
            text = maps.read_text()
        except OSError:  # gone, or another user's
            continue
        for line in text.splitlines():
            path = line.partition("/dev/shm/")
            if path[1]:
                mapped.add("/dev/shm/" + path[2].removesuffix(" (deleted)"))
    return mapped
