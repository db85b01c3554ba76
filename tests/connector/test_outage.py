"""A service call made while the endpoint is down says so, instead of a timeout riddle."""

from __future__ import annotations

import dataclasses
import time

import pytest

from simbridge.connector import Connector
from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.errors import ServiceError
from tests.connector.conftest import FAST
from tests.waiting import wait_for


def test_call_during_endpoint_outage_names_the_unreachable_endpoint() -> None:
    endpoint = EndpointThread(EndpointOptions(port=0)).start()
    port = endpoint.port
    # the call's own 0.5 s ends it, not the default service timeout (far beyond any delay)
    options = dataclasses.replace(FAST, service_timeout=600.0)
    conn = Connector("127.0.0.1", port, options).connect()
    try:
        conn.register_ros_service("/reset", "std_srvs/Trigger")
        endpoint.stop()  # outage: nothing listens on the port any more
        assert wait_for(lambda: not conn.connected, 30)
        t0 = time.monotonic()
        with pytest.raises(ServiceError) as info:
            conn.call("/reset", b"", timeout=0.5)
        text = str(info.value)
        assert f"endpoint at 127.0.0.1:{port} was unreachable" in text
        assert "/reset was never sent" in text
        assert "srv_id 0" not in text
        assert time.monotonic() - t0 < 60  # generous: a loaded machine
    finally:
        conn.close()
