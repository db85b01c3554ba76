#!/usr/bin/env bash
# Install the Debian packages simbridge needs (ROS 1 from Debian, OSMesa for
# headless rendering). Does nothing when they are all present already.
# Usage: scripts/install-system-deps.sh [demo]
#   demo: only what the local demo needs (`make demo`): OSMesa, for the cameras and videos
#   rendered without a display. No argument: everything the test suite uses (`make test`).
set -euo pipefail

DEMO_PACKAGES=(libosmesa6)

PACKAGES=(
  ros-core rosbash python3-rospy python3-rostopic python3-rosservice python3-genpy
  python3-std-msgs python3-std-srvs python3-sensor-msgs python3-geometry-msgs
  python3-tf2-msgs python3-rosgraph-msgs libosmesa6
  # every Debian message package whose types the sim and the demos publish or subscribe
  # (tests/e2e/test_ros1_topics_echo.py checks `rostopic echo` of each): odometry, trajectories
  python3-nav-msgs python3-trajectory-msgs
  # rosmsg/rossrv (and rospack-tools): `rosmsg show` of `simbridge msg genpy` output
  python3-rosmsg rospack-tools
  # robot_state_publisher and tf2 buffers: the sim's /tf against RSP fed its /joint_states
  # (tests/e2e/test_ros1_robot_state_publisher.py)
  ros-robot-state-publisher python3-tf2-ros
  # `rosbag info` of the sim's ROS 1 recordings (tests/sim/record/test_record.py)
  python3-rosbag
  # ROS 2 interface packages are compiled into .venv-ros2 (`simbridge msg build`); the
  # localhost-only test runs DDS in a private network namespace (unshare, ip)
  gcc g++ util-linux iproute2
  # real actionlib clients against the sim's controllers (tests/e2e/test_ros1_actionlib.py)
  python3-actionlib python3-actionlib-msgs
  # headless Chromium opens the live view (`simbridge sim --view`) in tests/sim/view/test_view.py
  chromium
  # RViz for ROS 1 (`simbridge rviz`), drawn under Xvfb in tests/e2e/test_rviz.py, which
  # reads the screenshot from Xvfb's framebuffer file (-fbdir); nothing else is needed
  rviz xvfb
  # a CPU hog beside the suite: used by `make test-loaded` (scripts/test-loaded.sh)
  stress-ng
)

if [ "${1:-}" = demo ]; then
  PACKAGES=("${DEMO_PACKAGES[@]}")
elif [ -n "${1:-}" ]; then
  echo "usage: $0 [demo]" >&2
  exit 2
fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "simbridge: installing system packages: ${missing[*]}"
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO=sudo; else
    echo "simbridge: not root and no sudo; install these by hand: ${missing[*]}" >&2
    exit 1
  fi
else
  SUDO=
fi
$SUDO apt-get update -q
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
