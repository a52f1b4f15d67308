"""Writing rosbag2 bags in MCAP storage through the ``mcap`` package's public writer.

A bag is a directory holding one ``<name>.mcap`` and, once closed,
``metadata.yaml`` (rosbag2's format, version 9): what ``ros2 bag`` writes
with its MCAP storage plugin, so ``ros2 bag info``/``play``, rosbags and
Foxglove read it as they read ros2's own. The .mcap is in the ``ros2``
profile: one ``ros2msg`` schema per message type (its definition as
rosbags' typestore generates it), one ``cdr`` channel per topic with its
``offered_qos_profiles``, and the bag's metadata in a ``rosbag2`` metadata
record, as rosbag2's MCAP plugin writes them.

Every ``flush_period_ns`` of log time the chunk in progress is closed and
pushed to disk (``mcap.writer.Writer.flush``, public), so a writer killed
with SIGKILL loses at most that much: the file then has no summary, footer
or metadata.yaml, and bag.iter_messages reads it up to its last chunk.
"""
from __future__ import annotations

import os
from importlib.metadata import version
from pathlib import Path

import yaml

from .bag import BagError, typestore

BAG_VERSION = 9                # rosbag2 metadata version (Jazzy and later)
ROS_DISTRO = os.environ.get("ROS_DISTRO") or "kilted"   # the ros-kilted-* wheels set none


class BagWriter:
    """A rosbag2 (MCAP) writer that flushes a chunk every ``flush_period_ns`` of log time."""

    def __init__(self, path, flush_period_ns: int = 10_000_000_000):
        from mcap.writer import CompressionType, Writer
        self.path = Path(path)
        if self.path.exists():
            raise BagError(f"{self.path}: already exists")
        self.path.mkdir(parents=True)
        self.file = self.path / f"{self.path.name}.mcap"
        self.stream = open(self.file, "xb")
        # uncompressed chunks, as before: the readers stream them, the bags stay what they were
        self.writer = Writer(self.stream, compression=CompressionType.NONE)
        self.writer.start(profile="ros2", library=f"rw_fdi_ros (mcap {version('mcap')})")
        self.schemas = {}       # message type -> schema id
        self.channels = {}      # topic -> (channel id, message type)
        self.counts = {}        # topic -> messages written
        self.custom_data = {}
        self.first = self.last = None
        self.flush_period_ns = flush_period_ns
        self.next_flush = flush_period_ns
        self.count = 0

    def add_topic(self, topic: str, type_name: str, qos: dict | None = None):
        """``qos``: the profile the topic is offered with, in rosbag2's v9 form (graph.convert.offered_qos), so
        that a player offers it again (a latched /scenario re-latched); None: none recorded."""
        if type_name not in self.schemas:
            msgdef, _ = typestore().generate_msgdef(type_name, ros_version=2)
            self.schemas[type_name] = self.writer.register_schema(type_name, "ros2msg", msgdef.encode())
        profiles = [qos] if qos else []
        channel = self.writer.register_channel(topic, "cdr", self.schemas[type_name], {
            "offered_qos_profiles": yaml.safe_dump(profiles, sort_keys=False).strip() if profiles else ""})
        self.channels[topic] = (channel, type_name, profiles)
        self.counts[topic] = 0

    def write(self, topic: str, log_time_ns: int, raw: bytes):
        self.writer.add_message(self.channels[topic][0], log_time_ns, bytes(raw), log_time_ns)
        self.counts[topic] += 1
        self.count += 1
        self.first = log_time_ns if self.first is None else min(self.first, log_time_ns)
        self.last = log_time_ns if self.last is None else max(self.last, log_time_ns)
        if log_time_ns >= self.next_flush:
            self.flush()
            self.next_flush = log_time_ns + self.flush_period_ns

    def write_message(self, topic: str, log_time_ns: int, msg):
        """Write a rosbags message object (tests and offline tools that make bags)."""
        self.write(topic, log_time_ns, typestore().serialize_cdr(msg, self.channels[topic][1]))

    def flush(self):
        """Close the chunk in progress and push everything written so far to disk."""
        self.writer.flush()

    def set_custom_data(self, key: str, value: str):
        if not isinstance(value, str):
            raise BagError(f"custom_data {key!r}: a string, got {value!r}")
        self.custom_data[key] = value

    def metadata(self) -> dict:
        """rosbag2_bagfile_information of what was written (metadata.yaml's one key)."""
        start, duration = self.first or 0, max(0, (self.last or 0) - (self.first or 0))
        store = typestore()
        return {
            "version": BAG_VERSION, "storage_identifier": "mcap", "relative_file_paths": [self.file.name],
            "duration": {"nanoseconds": duration}, "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": self.count,
            "topics_with_message_count": [
                {"topic_metadata": {"name": topic, "type": type_name, "serialization_format": "cdr",
                                    "offered_qos_profiles": list(profiles),
                                    "type_description_hash": store.hash_rihs01(type_name)},
                 "message_count": self.counts[topic]}
                for topic, (_, type_name, profiles) in self.channels.items()],
            "compression_format": "", "compression_mode": "",
            "files": [{"path": self.file.name, "starting_time": {"nanoseconds_since_epoch": start},
                       "duration": {"nanoseconds": duration}, "message_count": self.count}],
            "custom_data": dict(self.custom_data) or None, "ros_distro": ROS_DISTRO,
        }

    def close(self):
        """Summary, footer and metadata.yaml: a finished bag (metadata.yaml last, written whole)."""
        info = self.metadata()
        self.writer.add_metadata("rosbag2", {"serialized_metadata": yaml.safe_dump(info, sort_keys=False).strip()})
        self.writer.finish()
        self.stream.close()
        tmp = self.path / "metadata.yaml.tmp"
        tmp.write_text(yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False))
        tmp.replace(self.path / "metadata.yaml")
