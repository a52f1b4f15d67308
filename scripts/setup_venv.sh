#!/usr/bin/env bash
# Create or reuse .venv/ and install what rw_fdi_ros needs; a no-op when nothing changed.
set -euo pipefail
cd "$(dirname "$0")/.."
unset _ROS_WHEELS_BOOTSTRAP_COMPLETE   # a parent venv's ROS bootstrap must not leak into ours
PY=${PYTHON:-python3}

# Basilisk (AVS Lab), the reference our plant is checked against (test/test_basilisk.py), in an
# environment of its own: its pins (matplotlib, tqdm) clash with ours.
BSK=bsk==2.12.1
if [ ! -x .venv-bsk/bin/python ] || [ "$(cat .venv-bsk/.installed 2>/dev/null)" != "$BSK" ]; then
  echo "setting up .venv-bsk ($BSK, about 600 MB) ..." >&2
  rm -rf .venv-bsk
  "$PY" -m venv .venv-bsk
  .venv-bsk/bin/python -m pip install -q "$BSK" 2>&1 | grep -v "^WARNING: Location" >&2 || true
  .venv-bsk/bin/python -c "from Basilisk.simulation import reactionWheelStateEffector" \
    || { echo "setup: Basilisk import failed" >&2; exit 1; }
  echo "$BSK" > .venv-bsk/.installed
fi

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
