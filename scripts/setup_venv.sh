#!/usr/bin/env bash
# Create or reuse .venv/ and install what rw_fdi_ros needs; a no-op when nothing changed.
# (The tests' Basilisk cross-check has an environment of its own: scripts/setup_basilisk.sh.)
set -euo pipefail
cd "$(dirname "$0")/.."
unset _ROS_WHEELS_BOOTSTRAP_COMPLETE   # a parent venv's ROS bootstrap must not leak into ours
PY=${PYTHON:-python3}

stamp=.venv/.rw_fdi_installed
want=$(cat requirements.txt setup.py | sha256sum | cut -d' ' -f1)
if [ -x .venv/bin/python ] && [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
  exit 0
fi
echo "setting up .venv (ROS 2 kilted wheels, numpy, scipy, torch 2.13.0 CPU, rosbags, mcap) ..." >&2
[ -x .venv/bin/python ] || "$PY" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip >/dev/null
.venv/bin/python -m pip install -q -r requirements.txt
.venv/bin/python -m pip install -q --no-deps -e . >/dev/null 2>&1 || .venv/bin/python -m pip install --no-deps -e .
.venv/bin/python -c "import rclpy, torch, rosbags, mcap" || { echo "setup: imports failed" >&2; exit 1; }
echo "$want" > "$stamp"
echo "setup: .venv ready" >&2
