#!/usr/bin/env bash
# The main job: a fault scenario through the whole recorded graph, summary printed.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_venv.sh
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST   # the launcher also sets it, and a private domain per run
exec .venv/bin/rw-fdi run --scenario "${1:-fdir_bus_x}" "${@:2}"
