#!/usr/bin/env bash
# Basilisk (AVS Lab), the reference our plant is checked against (test/test_basilisk.py), in an environment of
# its own, .venv-bsk: its pins (matplotlib, tqdm) clash with ours. Only the tests need it (about 600 MB).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
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
