"""`__set_param` on the ROS 1 backend: rospy.set_param on the master, refused values named,
and set again by register_again (what MasterWatch runs when a restarted master, which
starts with no parameters, does not know the node)."""

from __future__ import annotations

import asyncio
import xmlrpc.client
from typing import Any

import pytest
from tests.ros1support import RosMaster, require_ros, with_backend

require_ros(module_level=True)

from simbridge.endpoint.backends.ros1 import Ros1Backend  # noqa: E402
from simbridge.endpoint.backends.ros1.rejoin import register_again  # noqa: E402
from simbridge.errors import EndpointError  # noqa: E402

pytestmark = [
    pytest.mark.ros1,
    pytest.mark.timeout(120),
    pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning"),
]

URDF = '<robot name="r"><link name="base"/></robot>'


def test_set_param_reaches_the_master_and_survives_a_restart(master: RosMaster) -> None:
    api: Any = xmlrpc.client.ServerProxy(master.uri)

    async def scenario(backend: Ros1Backend) -> None:
        await backend.set_param("/sbp/robot_description", URDF)
        await backend.set_param("/sbp/limits", {"max": [1.5, 2], "on": True})
        assert api.getParam("/t", "/sbp/robot_description")[2] == URDF
        assert api.getParam("/t", "/sbp/limits")[2] == {"max": [1.5, 2], "on": True}
        assert master.run(["rosparam", "get", "/sbp/robot_description"]).stdout.strip() == URDF
        api.deleteParam("/t", "/sbp")  # as a restarted master has it: no parameters
        assert api.getParam("/t", "/sbp/robot_description")[0] != 1
        await asyncio.to_thread(register_again, master.uri)
        assert api.getParam("/t", "/sbp/robot_description")[2] == URDF
        assert api.getParam("/t", "/sbp/limits")[2] == {"max": [1.5, 2], "on": True}

    with_backend(scenario)


def test_bad_parameters_are_named(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> None:
        with pytest.raises(EndpointError, match=r"parameter name '/a b' is not a legal ROS name"):
            await backend.set_param("/a b", 1)
        with pytest.raises(EndpointError, match=r"cannot set parameter '/sbp/huge'"):
            await backend.set_param("/sbp/huge", 2**40)  # XML-RPC ints are 32 bits

    with_backend(scenario)
