"""Shared test set-up: every ROS process the tests start stays on loopback in a private domain."""
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="rw_fdi_test_roslog_"))
os.environ.pop("ROS_LOCALHOST_ONLY", None)
