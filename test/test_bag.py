"""Bag writing and reading, including a summary-less, truncated MCAP (killed recorder)."""
import shutil

import pytest
from rosbags.typesys.stores.ros2_kilted import builtin_interfaces__msg__Time as Time
from rosbags.typesys.stores.ros2_kilted import geometry_msgs__msg__Vector3 as Vector3
from rosbags.typesys.stores.ros2_kilted import geometry_msgs__msg__Vector3Stamped as V3S
from rosbags.typesys.stores.ros2_kilted import std_msgs__msg__Header as Header

from rw_fdi_ros.storage.bag import BagError, bag_is_complete, read_bag, typestore
from rw_fdi_ros.storage.writer import BagWriter
from rw_fdi_ros.storage.cdr import header_stamp_ns


def vec(t_ns, x):
    return V3S(header=Header(stamp=Time(sec=t_ns // 10**9, nanosec=t_ns % 10**9), frame_id="body"),
               vector=Vector3(x=x, y=2 * x, z=3 * x))


def write(path, n, flush_period_ns=10**9, close=True):
    w = BagWriter(path, flush_period_ns)
    w.add_topic("/a", "geometry_msgs/msg/Vector3Stamped")
    for k in range(n):
        w.write_message("/a", k * 10**8, vec(k * 10**8, float(k)))
    if close:
        w.close()
    return w


def test_roundtrip_complete_bag(tmp_path):
    write(tmp_path / "b", 50)
    assert bag_is_complete(tmp_path / "b")
    data = read_bag(tmp_path / "b")
    assert data.complete and len(data.topic("/a")) == 50
    t, v = data.vectors("/a")
    assert t[-1] == pytest.approx(4.9) and v[-1].tolist() == [49.0, 98.0, 147.0]


def test_header_stamp_from_raw_cdr():
    raw = typestore().serialize_cdr(vec(12_345_678_901, 1.0), "geometry_msgs/msg/Vector3Stamped")
    assert header_stamp_ns(bytes(raw), -1) == 12_345_678_901


def test_killed_writer_leaves_a_readable_prefix(tmp_path):
    _writer = write(tmp_path / "k", 100, flush_period_ns=10**9, close=False)  # as if SIGKILLed: no close
    assert not bag_is_complete(tmp_path / "k")
    data = read_bag(tmp_path / "k")
    assert not data.complete
    n = len(data.topic("/a"))
    assert 90 <= n < 100                      # every flushed chunk, not the pending one
    t, _ = data.vectors("/a")
    assert list(t) == sorted(t)


def test_truncated_file_mid_chunk(tmp_path):
    write(tmp_path / "t", 100)
    f = next((tmp_path / "t").glob("*.mcap"))
    size = f.stat().st_size
    with open(f, "r+b") as fh:
        fh.truncate(size // 2)
    data = read_bag(tmp_path / "t")
    assert not data.complete and "truncated" in data.note
    assert 0 < len(data.topic("/a")) < 100


def test_not_a_bag_is_one_line_error(tmp_path):
    with pytest.raises(BagError, match="no .mcap"):
        read_bag(tmp_path)
    (tmp_path / "x.mcap").write_bytes(b"garbage")
    with pytest.raises(BagError):
        read_bag(tmp_path)


def test_writer_refuses_to_overwrite(tmp_path):
    write(tmp_path / "b", 1)
    with pytest.raises(BagError, match="already exists"):
        BagWriter(tmp_path / "b")
    shutil.rmtree(tmp_path / "b")


def test_flush_puts_what_was_written_on_disk(tmp_path):
    """BagWriter.flush closes the pending chunk and writes it out: a reader sees every message so far
    without the writer closing (what keeps a SIGKILLed recorder's bag)."""
    w = write(tmp_path / "f", 30, flush_period_ns=10**12, close=False)   # no flush on its own
    before = read_bag(tmp_path / "f").topic("/a") if next((tmp_path / "f").glob("*.mcap")).stat().st_size else []
    w.flush()
    after = read_bag(tmp_path / "f")
    assert len(before) < 30 and len(after.topic("/a")) == 30 and not after.complete
    w.close()


def test_a_bag_is_what_rosbag2_writes_and_rosbags_reads_it(tmp_path):
    """The writer is the mcap package's public one: the ros2 profile, a ros2msg schema per type, cdr channels
    with their QoS, the rosbag2 metadata record, metadata.yaml version 9 with every topic's count and type
    hash; rosbags' own reader (as ros2 bag would) reads it back message for message."""
    import yaml
    from mcap.reader import make_reader
    from rosbags.rosbag2 import Reader
    w = write(tmp_path / "r", 25, close=False)
    w.set_custom_data("engine", "graph")
    w.close()
    meta = yaml.safe_load((tmp_path / "r" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["version"] == 9 and meta["storage_identifier"] == "mcap" and meta["message_count"] == 25
    assert meta["relative_file_paths"] == ["r.mcap"] and meta["custom_data"] == {"engine": "graph"}
    topic = meta["topics_with_message_count"][0]
    assert topic["message_count"] == 25 and topic["topic_metadata"]["type"] == "geometry_msgs/msg/Vector3Stamped"
    assert topic["topic_metadata"]["type_description_hash"].startswith("RIHS01_")
    assert meta["duration"]["nanoseconds"] == 24 * 10**8
    with open(tmp_path / "r" / "r.mcap", "rb") as fh:
        reader = make_reader(fh)
        header, summary = reader.get_header(), reader.get_summary()
        assert header.profile == "ros2" and summary.statistics.message_count == 25
        assert [s.encoding for s in summary.schemas.values()] == ["ros2msg"]
        assert [(c.topic, c.message_encoding) for c in summary.channels.values()] == [("/a", "cdr")]
        assert "offered_qos_profiles" in next(iter(summary.channels.values())).metadata
        assert [m.name for m in reader.iter_metadata()] == ["rosbag2"]
    with Reader(tmp_path / "r") as reader:
        assert reader.message_count == 25 and reader.ros_distro == "kilted"
        got = [typestore().deserialize_cdr(raw, c.msgtype).vector.x for c, _, raw in reader.messages()]
    assert got == [float(k) for k in range(25)]


def test_a_recorded_topic_keeps_the_qos_it_was_offered_with(tmp_path):
    """The recorder's QoS in rosbag2's v9 form, in metadata.yaml and in the MCAP channel (issue 38): rosbags
    (as ros2 bag play would) reads a latched topic back as transient-local, a per-step one as volatile."""
    from rosbags.interfaces import QosDurability, QosReliability
    from rosbags.rosbag2 import Reader
    from rosbags.typesys.stores.ros2_kilted import std_msgs__msg__String as String

    from rw_fdi_ros.graph import topics as T
    from rw_fdi_ros.graph.convert import offered_qos
    from rw_fdi_ros.storage.writer import BagWriter
    w = BagWriter(tmp_path / "q")
    w.add_topic(T.SCENARIO, "std_msgs/msg/String", offered_qos(T.LATCHED))
    w.add_topic(T.CLOCK, "rosgraph_msgs/msg/Clock", offered_qos(T.RELIABLE))
    w.write_message(T.SCENARIO, 0, String(data="name: x"))
    w.close()
    with Reader(tmp_path / "q") as reader:
        qos = {c.topic: c.ext.offered_qos_profiles[0] for c in reader.connections}
    assert qos[T.SCENARIO].durability == QosDurability.TRANSIENT_LOCAL and qos[T.SCENARIO].depth == 1
    assert qos[T.CLOCK].durability == QosDurability.VOLATILE and qos[T.CLOCK].depth == 1000
    assert {q.reliability for q in qos.values()} == {QosReliability.RELIABLE}


def _mixed_bag(path, close=True):
    """Vector3Stamped and JointState rows written out of stamp order, ties across topics, a latched
    String and a DiagnosticArray: what the streaming readers must give back as the decoded reader does."""
    from rosbags.typesys.stores.ros2_kilted import diagnostic_msgs__msg__DiagnosticArray as DiagArray
    from rosbags.typesys.stores.ros2_kilted import sensor_msgs__msg__JointState as JointState
    from rosbags.typesys.stores.ros2_kilted import std_msgs__msg__String as String
    import numpy as np
    w = BagWriter(path, 10**9)
    for topic, kind in (("/a", "geometry_msgs/msg/Vector3Stamped"), ("/j", "sensor_msgs/msg/JointState"),
                        ("/scenario", "std_msgs/msg/String"), ("/d", "diagnostic_msgs/msg/DiagnosticArray")):
        w.add_topic(topic, kind)
    w.write_message("/scenario", 0, String(data="name: x"))
    for k in (0, 2, 1, 3, 5, 4, 6, 7, 9, 8) * 3:   # each stamp three times: ties within a topic too
        t = k * 10**9 + 10**8 + 7   # not whole seconds: the float of a stamp must match the decoded reader's
        stamp = Time(sec=t // 10**9, nanosec=t % 10**9)
        w.write_message("/j", t, JointState(header=Header(stamp=stamp, frame_id=""), name=["a", "b"],
                                            position=np.array([k, -k], float), velocity=np.array([0.5 * k, 1.0]),
                                            effort=np.array([], float)))
        w.write_message("/a", t, vec(t, k / 3))
        w.write_message("/d", t, DiagArray(header=Header(stamp=stamp, frame_id=""), status=[]))
    if close:
        w.close()


def test_series_gives_the_numbers_of_the_decoded_reader(tmp_path):
    import numpy as np
    from rw_fdi_ros.storage.bag import bag_info, read_series
    _mixed_bag(tmp_path / "m")
    full, series = read_bag(tmp_path / "m"), read_series(tmp_path / "m", ["/a", "/j", "/scenario", "/d"])
    for got, want in zip(series.vectors("/a"), full.vectors("/a")):
        np.testing.assert_array_equal(got, want)
    for got, want in zip(series.joint_states("/j"), full.joint_states("/j")):
        assert got.shape == want.shape
        np.testing.assert_array_equal(got, want)
    assert series.scenario_text == full.scenario_text == "name: x"
    assert series.last("/d").header.stamp.sec == full.last("/d").header.stamp.sec == 9
    assert series.last("/d").header.stamp.nanosec == 100_000_007
    assert series.vectors("/missing")[0].size == 0 and series.complete
    info = bag_info(tmp_path / "m")
    assert info.counts == {t: len(full.topic(t)) for t in full.messages} == {"/scenario": 1, "/j": 30, "/a": 30,
                                                                            "/d": 30}
    assert info.span["/a"] == [100_000_007, 9_100_000_007]


@pytest.mark.parametrize("complete", [True, False])
def test_time_order_is_the_sorted_bag(tmp_path, complete):
    """The player's stream equals sorting the whole bag by (log time, topic rank), stable in file order;
    through the chunk index for a finished bag, whole for one a killed recorder left."""
    from rw_fdi_ros.storage.bag import iter_time_order
    _mixed_bag(tmp_path / "o", close=complete)
    rank = {"/d": 0, "/a": 1, "/j": 2}.get
    data = read_bag(tmp_path / "o", raw=True)
    assert data.complete == complete
    rows = [(t, topic, raw) for topic, msgs in data.messages.items() for t, raw in msgs]
    want = sorted(rows, key=lambda r: (r[0], rank(r[1], 99)))
    got = list(iter_time_order(tmp_path / "o", None, lambda t: rank(t, 99)))
    assert [(t, topic) for t, topic, _ in got] == [(t, topic) for t, topic, _ in want]
    assert [bytes(r) for _, _, r in got] == [bytes(r) for _, _, r in want]
    assert len(got) == (91 if complete else len(rows))


def _damage_message(path, k):
    """Overwrite 8 bytes of message k's data inside its chunk (the file's structure left whole)."""
    f = next(path.glob("*.mcap"))
    blob = bytearray(f.read_bytes())
    raw = bytes(typestore().serialize_cdr(vec(k * 10**8, float(k)), "geometry_msgs/msg/Vector3Stamped"))
    at = blob.find(raw)
    assert at > 0
    blob[at + len(raw) - 8:at + len(raw)] = b"\xde\xad\xbe\xef" * 2
    f.write_bytes(bytes(blob))


def test_a_chunk_that_fails_its_crc_is_skipped_counted_and_refused_where_data_must_be_intact(tmp_path):
    """4 KB of random bytes in the middle of a bag read as `complete` and its messages went into training (issue
    39): each chunk is checked against its CRC; a damaged one is skipped and said, the rest read, and the tools
    that train, fit and judge (intact=True) refuse the bag by name."""
    write(tmp_path / "d", 100)
    _damage_message(tmp_path / "d", 50)
    assert bag_is_complete(tmp_path / "d")          # the quick check sees the footer and metadata only
    data = read_bag(tmp_path / "d")
    assert not data.complete and data.note.startswith("damaged: 1 chunk(s) fail their CRC"), data.note
    assert 80 <= len(data.topic("/a")) < 100 and 50 * 10**8 not in [t for t, _ in data.topic("/a")]
    with pytest.raises(BagError, match=r"d: damaged: 1 chunk\(s\)"):
        read_bag(tmp_path / "d", intact=True)
    from rw_fdi_ros.storage.bag import read_series
    with pytest.raises(BagError, match="damaged"):
        read_series(tmp_path / "d", ["/a"], intact=True)
    from rw_fdi_ros.tools.design.samples import load_samples
    skipped = []
    assert load_samples(tmp_path, on_skip=skipped.append) == [] and len(skipped) == 1 and "damaged" in skipped[0]


@pytest.mark.parametrize("damage, said", [
    (lambda b: (b / "metadata.yaml").unlink(), "metadata.yaml missing"),
    (lambda b: (b / "metadata.yaml").write_text("rosbag2_bagfile_information: [1, 2"), "unreadable metadata"),
    (lambda b: (b / "metadata.yaml").write_text((b / "metadata.yaml").read_text().replace("message_count: 100",
                                                                                        "message_count: 90")),
     "metadata.yaml counts 90 messages, the file holds 100")])
def test_a_bag_whose_metadata_is_missing_broken_or_wrong_is_not_complete(tmp_path, damage, said):
    write(tmp_path / "m", 100)
    damage(tmp_path / "m")
    data = read_bag(tmp_path / "m")
    assert not data.complete and said in data.note and len(data.topic("/a")) == 100, data.note


def test_a_bag_without_a_message_is_not_complete(tmp_path):
    """A recorder closed before any message: footer and metadata, and nothing to judge."""
    w = BagWriter(tmp_path / "e", 10**9)
    w.add_topic("/a", "geometry_msgs/msg/Vector3Stamped")
    w.close()
    data = read_bag(tmp_path / "e")
    assert not data.complete and data.note == "no messages"


def test_rw_fdi_bag_says_a_damaged_bag_is_damaged_and_fails(tmp_path, capsys):
    """`rw-fdi bag` on 4 KB of random bytes in a bag said `complete`, exit 0 (issue 39)."""
    from rw_fdi_ros.cli import main
    write(tmp_path / "d", 100)
    _damage_message(tmp_path / "d", 30)
    assert main(["bag", str(tmp_path / "d")]) == 1
    out, err = capsys.readouterr()
    assert "incomplete: damaged: 1 chunk(s)" in out and "/a" in out
    assert err.strip().startswith("rw-fdi: error:") and "messages read" in err and "\n" not in err.strip()


def test_two_writers_of_one_topic_at_one_log_time_compare_in_either_order(tmp_path):
    """/diagnostics has two writers each FDI period (the isolation node, the wheel allocation): the recorder
    gets them in either order, which is the same run; different contents at that time are not."""
    from rw_fdi_ros.storage.compare import bag_differences

    def bag(name, values):
        w = BagWriter(tmp_path / name)
        w.add_topic("/a", "geometry_msgs/msg/Vector3Stamped")
        for k, x in values:
            w.write_message("/a", k * 10**9, vec(k * 10**9, x))
        w.close()
        return tmp_path / name
    a = bag("a", [(0, 1.0), (1, 2.0), (1, 3.0), (2, 4.0)])
    assert bag_differences(a, bag("b", [(0, 1.0), (1, 3.0), (1, 2.0), (2, 4.0)])) == []
    assert bag_differences(a, bag("e", [(0, 1.0), (1, 2.0), (2, 4.0), (1, 3.0)])) == []   # a late arrival
    assert bag_differences(a, bag("c", [(0, 1.0), (1, 3.0), (1, 5.0), (2, 4.0)])) == \
        ["/a message 1 (t = 1 s): contents differ"]
    assert bag_differences(a, bag("d", [(0, 1.0), (1, 2.0), (2, 3.0), (2, 4.0)])) == \
        ["/a message 2: stamp 1000000000 in a, 2000000000 in d"]


def test_a_damaged_record_header_is_named_and_every_whole_chunk_after_it_read(tmp_path, capsys):
    """16 random bytes over the third chunk's record header read as 'truncated' with exit 0, and the chunks
    after it were never read (issue 56): the record is named, reading goes on at the next whole chunk, and
    `rw-fdi bag` fails, also in --json."""
    import json

    from mcap.reader import make_reader

    from rw_fdi_ros.cli import main
    write(tmp_path / "h", 100)                       # 10 chunks of 10 messages (a 1-s flush period)
    f = next((tmp_path / "h").glob("*.mcap"))
    with open(f, "rb") as fh:
        chunks = sorted(c.chunk_start_offset for c in make_reader(fh).get_summary().chunk_indexes)
    assert len(chunks) >= 5
    blob = bytearray(f.read_bytes())
    blob[chunks[2]:chunks[2] + 16] = bytes(range(200, 216))
    f.write_bytes(bytes(blob))
    info = read_bag(tmp_path / "h")
    assert not info.complete and "damaged at record" in info.note, info.note
    times = [t for t, _ in info.topic("/a")]
    assert times[-1] == 99 * 10**8 and 70 <= len(times) < 100   # the chunks beyond the damaged one read
    with pytest.raises(BagError, match="damaged at record"):
        read_bag(tmp_path / "h", intact=True)
    assert main(["bag", str(tmp_path / "h"), "--json"]) == 1
    said = json.loads(capsys.readouterr().out)
    assert said["complete"] is False and "damaged at record" in said["damage"] and "messages after it read" in \
        said["damage"]


def test_a_bag_folder_with_two_mcap_files_is_refused_by_name(tmp_path):
    """A folder holding two .mcap files was read by its first alone, the other's messages dropped in silence
    (issue 56)."""
    write(tmp_path / "two", 20)
    f = next((tmp_path / "two").glob("*.mcap"))
    shutil.copy(f, f.with_name("second.mcap"))
    with pytest.raises(BagError, match=r"two: 2 .mcap files \(.*second.mcap.*\); a bag here holds one"):
        read_bag(tmp_path / "two")
