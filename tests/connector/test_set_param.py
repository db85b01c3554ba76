"""`Connector.set_param`: sent to endpoints that announce `set_param`, set again on every
connection, never sent to the original endpoint (a warning instead); the local bus keeps
parameters and reports failures as `__error`."""

from __future__ import annotations

import logging

import pytest

import simbridge.endpoint.backends.local as local_module
from simbridge.connector import Connector
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus
from simbridge.errors import ConnectorError
from simbridge.protocol import CommandReceived, SetParam
from tests.connector.fake_endpoint import FakeEndpoint
from tests.waiting import wait_for


def _set_params(endpoint: FakeEndpoint, conn: int = -1) -> list[SetParam]:
    return [
        e.command
        for e in endpoint.events(conn)
        if isinstance(e, CommandReceived) and isinstance(e.command, SetParam)
    ]


def test_sent_before_and_after_connecting_and_again_on_reconnect(make_connector) -> None:
    with FakeEndpoint(keepalive=0.2, extensions=["set_param"]) as modern:
        conn = make_connector(modern.port)
        conn.set_param("/robot_description", "<robot name='a'/>")  # held until connected
        conn.connect()
        conn.set_param("/rate", 50)
        assert modern.wait_for(lambda: len(_set_params(modern)) == 2)
        assert _set_params(modern) == [
            SetParam("/robot_description", "<robot name='a'/>"),
            SetParam("/rate", 50),
        ]
        for client in modern.live_conns():
            client.close()
        assert modern.wait_conns(2)
        assert modern.wait_for(lambda: len(_set_params(modern)) == 2)  # the new connection's
        assert {p.name for p in _set_params(modern)} == {"/robot_description", "/rate"}


def test_original_endpoint_is_never_sent_it(make_connector, caplog) -> None:
    with FakeEndpoint(keepalive=None) as original, caplog.at_level(logging.WARNING):
        conn = make_connector(original.port)
        conn.set_param("/robot_description", "<robot/>")
        conn.connect()
        conn.set_param("/other", 1)
        conn.register_publisher("/t", "std_msgs/String")
        assert original.wait_for(lambda: len(original.events()) >= 1)
        assert _set_params(original) == []
    text = caplog.text
    assert "does not offer the set_param extension" in text
    assert "/robot_description" in text
    assert "/other" in text


def test_bad_values_are_refused_before_sending(make_connector) -> None:
    conn = make_connector(1)
    with pytest.raises(ConnectorError, match="cannot be None"):
        conn.set_param("/a", None)
    with pytest.raises(ConnectorError, match="not JSON"):
        conn.set_param("/a", object())
    with pytest.raises(ConnectorError, match="contains whitespace"):
        conn.set_param("/a b", 1)
    with pytest.raises(ConnectorError, match="a system command holds at most"):
        conn.set_param("/big", "x" * (2 * 1024 * 1024))


def test_local_bus_keeps_parameters_and_reports_failures(monkeypatch, caplog) -> None:
    bus = LocalBus()
    with (
        EndpointThread(EndpointOptions(port=0), bus) as endpoint,
        Connector("127.0.0.1", endpoint.port).connect() as conn,
    ):
        conn.set_param("/robot_description", "<robot name='r'/>")
        conn.set_param("/limits", {"max": [1, 2]})
        assert wait_for(lambda: bus.get_param("/limits") == {"max": [1, 2]})
        assert bus.get_param("/robot_description") == "<robot name='r'/>"
        monkeypatch.setattr(local_module, "MAX_PARAMS", 2)
        with caplog.at_level(logging.ERROR, logger="simbridge.connector"):
            conn.set_param("/third", 3)
            assert wait_for(lambda: "__set_param '/third' failed" in caplog.text)
        assert "holds 2 parameters (the limit)" in caplog.text
        assert bus.get_param("/third") is None
