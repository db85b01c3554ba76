"""ROS 1 message types for simbridge, built on rosbags.

`default_registry()` returns the shared MessageRegistry: every ROS 1 noetic type
in rosbags' typestore plus the definitions shipped in `definitions/` (a moveit_msgs
subset, niryo_moveit from Unity's pick-and-place tutorial, tf2_msgs, std_srvs,
move_base_msgs, roscpp, sensor_msgs and nav_msgs services). More packages load from
directories in the ROS layout with `registry.load_packages(path)`; `.action` files
expand like genmsg's.

Names: `pkg/Type` is canonical; `pkg/msg/Type` is accepted too. Services are
`pkg/Srv` (or `pkg/srv/Srv`); their parts `pkg/SrvRequest` / `pkg/SrvResponse`
are ordinary message types.

MessageRegistry API:
- `has(name)`, `resolve(name) -> "pkg/Type"` (UnknownMessageTypeError names close matches),
  `names()`, `service_names()`, `has_service(name)`.
- `md5(name)`: genmsg md5 of a message or service; `definition(name)`: full text as
  rospy `_full_text` / TCPROS `message_definition`; `text(name)`; `dependencies(name)`;
  `schema(name)`: field layout; `show(name)`: `rosmsg show` / `rossrv show` text.
- `service(name) -> ServiceInfo(name, request, response, md5)`.
- `new(name, **fields)`: zero-initialised message (rosbags dataclass, mutable:
  `msg.linear.x = 0.5`); `from_dict`, `to_dict`, `to_json`/`from_json`,
  `to_msgpack`/`from_msgpack`, `from_yaml` (rostopic-pub style). `to_json` writes strict
  JSON: NaN and +-Infinity become null (as rosbridge does), and null reads back as NaN.
- `encode(msg, name=None, fmt="ros1"|"cdr") -> bytes`, `decode(data, name, fmt)`,
  `transcode(data, name, src, dst)`; `codec(name)` gives the cached per-type Codec
  for hot paths (`Codec.encode_buffer` skips the final copy of large messages).
  Malformed input raises MessageError, never anything else.
- `load_packages(*paths)`, `add_message(name, text)`, `add_service(name, text)`.

Module functions `show(name)` and `md5(name)` use the default registry (for the CLI).

Messages are rosbags' generated (mutable) dataclasses. Numeric array fields hold numpy
arrays (`new`/`from_dict` convert lists; assigning a plain list fails at encode time);
arrays in decoded messages are read-only views of the input bytes. Time and duration
fields are `builtin_interfaces` Time/Duration objects (`sec`, `nanosec`); dicts spell
them `{secs, nsecs}` (or `[secs, nsecs]`, or float seconds) like rospy. ROS 1 binary
follows ROS 1: `time` is uint32 secs/nsecs (stamps past 2038 are valid), `duration`
int32 secs/nsecs; CDR keeps builtin_interfaces' `int32 sec, uint32 nanosec`. A value a
format cannot carry raises MessageError naming the field, the value and the range.
CDR uses the registry's layouts: ROS 1 noetic by default (Header with seq).

ROS 2 mode: `ros2_registry()` (or `registry_for("ROS2")`, `MessageRegistry(store=ROS2_STORE)`)
holds Jazzy layouts: Header without seq, `builtin_interfaces/Time` (int32 sec, uint32
nanosec, spelled `{sec, nanosec}` in dicts), CameraInfo with `d k r p`. Its `protocol` is
"ROS2" and its `wire_format` (the default of encode/decode) is "cdr". Packages load from
the same `pkg/msg`, `pkg/srv`, `pkg/action` layout, where a package's `ros2/` folder holds
the files whose ROS 2 layout differs (shipped control_msgs: Jazzy's, ROS 1 keeps noetic's);
actions expand as rosidl does (`pkg/FooGoal`, `pkg/FooFeedbackMessage`, services
`pkg/FooSendGoal`, `pkg/FooGetResult`).
`ros2_name(name)` gives the rosidl spelling (`pkg/msg/Type`, `pkg/srv/Srv_Request`,
`pkg/action/Foo_Goal`); every such spelling is accepted as input. A type without fields
(std_msgs/Empty, std_srvs/Trigger's request) is written in CDR as rclpy writes it (header,
rosidl's placeholder byte, padding) and read from that or from the header alone, as
Unity writes it (`simbridge.messages.empty`; `Codec.ros2_cdr` respells a payload).
`Translator(src, dst)` turns message objects of one registry's layouts into another's
(Header loses `seq`, CameraInfo `D` becomes `d`, ...), rebuilding only the parts that
differ.
"""

from __future__ import annotations

from .codec import Codec, WireFormat
from .loader import (
    ROS2_VARIANTS,
    InterfaceSources,
    expand_action,
    expand_action_ros2,
    interface_files,
    load_interface_dirs,
)
from .names import TypeName, parse_type_name
from .registry import (
    ROS2_STORE,
    SHIPPED_DEFINITIONS,
    MessageRegistry,
    default_registry,
    registry_for,
    ros2_registry,
)
from .schema import ConstantSpec, FieldSpec, MessageSchema
from .service_info import ServiceInfo
from .translate import Translator

__all__ = [
    "ROS2_STORE",
    "ROS2_VARIANTS",
    "SHIPPED_DEFINITIONS",
    "Codec",
    "ConstantSpec",
    "FieldSpec",
    "InterfaceSources",
    "MessageRegistry",
    "MessageSchema",
    "ServiceInfo",
    "Translator",
    "TypeName",
    "WireFormat",
    "default_registry",
    "expand_action",
    "expand_action_ros2",
    "interface_files",
    "load_interface_dirs",
    "md5",
    "parse_type_name",
    "registry_for",
    "ros2_registry",
    "show",
]


def show(name: str) -> str:
    """`rosmsg show` / `rossrv show` text of `name` from the default registry."""
    return default_registry().show(name)


def md5(name: str) -> str:
    """genmsg md5sum of message or service `name` from the default registry."""
    return default_registry().md5(name)
