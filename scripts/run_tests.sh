#!/usr/bin/env bash
# The test suite (about ten minutes on 2 cores); every ROS process stays on loopback in a private domain.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_venv.sh
bash scripts/setup_basilisk.sh   # test/test_basilisk.py's reference
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_LOG_DIR="$(mktemp -d /tmp/rw_fdi_test_roslog.XXXXXX)"
exec .venv/bin/python -m pytest -q -p no:cacheprovider -n 2 --dist loadgroup --durations=12 "$@" test
