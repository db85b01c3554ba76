"""The Fast DDS profile for a graph across hosts: UDP on one address, unicast peers only.

Fast DDS applying it is checked by tests/ros2/test_multi_host.py (simulated hosts)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from simbridge.endpoint.backends.ros2 import fastdds_peers_profile_xml
from simbridge.errors import EndpointError

NS = {"d": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}


def test_profile_lists_the_peers_once_and_only_udp_on_the_address() -> None:
    text = fastdds_peers_profile_xml(" 10.0.0.2", ["10.0.0.1", "10.0.0.2", "10.0.0.1"])
    root = ET.fromstring(text)
    transports = root.findall(".//d:transport_descriptor", NS)
    assert [t.findtext("d:type", namespaces=NS) for t in transports] == ["UDPv4"]
    assert [a.text for a in root.findall(".//d:interfaceWhiteList/d:address", NS)] == ["10.0.0.2"]
    peers = root.findall(".//d:initialPeersList/d:locator/d:udpv4/d:address", NS)
    assert [p.text for p in peers] == ["10.0.0.1", "10.0.0.2"]
    participant = root.find(".//d:participant", NS)
    assert participant is not None
    assert participant.get("is_default_profile") == "true"
    assert participant.findtext(".//d:useBuiltinTransports", namespaces=NS) == "false"
    assert participant.find(".//d:metatrafficUnicastLocatorList/d:locator", NS) is not None
    assert participant.find(".//d:metatrafficMulticastLocatorList", NS) is None
    assert "SHM" not in text


@pytest.mark.parametrize(
    ("address", "peers", "message"),
    [
        ("10.0.0.300", ["10.0.0.1"], "address '10.0.0.300' is not an IPv4 address"),
        ("10.0.0.2", ["host-a"], "peer 'host-a' is not an IPv4 address"),
        ("10.0.0.2", [], "no peers given"),
    ],
)
def test_bad_addresses_are_refused_by_name(address: str, peers: list[str], message: str) -> None:
    with pytest.raises(EndpointError, match=message):
        fastdds_peers_profile_xml(address, peers)
