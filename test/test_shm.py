"""Fast DDS shared-memory files of dead processes (runner/shm.py): what goes and what stays."""
import fcntl
import os
import time

from rw_fdi_ros.runner.shm import clean_zombie_files, zombie_files


def _touch(path, age=0.0):
    path.write_bytes(b"")
    old = time.time() - age
    os.utime(path, (old, old))


def test_only_files_no_live_process_holds_go(tmp_path):
    for name in ("fastdds_0123456789abcdef", "fastdds_port7411", "sem.fastdds_port7411_mutex",
                 "fastdds_fedcba9876543210", "fastdds_port7413", "fastdds_aaaaaaaaaaaaaaaa", "other_file"):
        _touch(tmp_path / name)
    _touch(tmp_path / "fastdds_0123456789abcdef_el", age=120)   # dead owner
    _touch(tmp_path / "fastdds_port7411_sl", age=120)           # dead owner
    _touch(tmp_path / "fastdds_fedcba9876543210_el", age=120)   # live owner: held below
    _touch(tmp_path / "fastdds_port7413_el", age=120)           # live owner
    _touch(tmp_path / "fastdds_aaaaaaaaaaaaaaaa_el", age=1)     # just made: its owner may not have locked it yet
    held = [open(tmp_path / n, "ab") for n in ("fastdds_fedcba9876543210_el", "fastdds_port7413_el")]
    for f in held:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
    try:
        gone = sorted(p.name for p in zombie_files(tmp_path))
        assert gone == ["fastdds_0123456789abcdef", "fastdds_0123456789abcdef_el", "fastdds_port7411",
                        "fastdds_port7411_sl", "sem.fastdds_port7411_mutex"]
        assert clean_zombie_files(tmp_path) == 5
        assert sorted(os.listdir(tmp_path)) == [
            "fastdds_aaaaaaaaaaaaaaaa", "fastdds_aaaaaaaaaaaaaaaa_el", "fastdds_fedcba9876543210",
            "fastdds_fedcba9876543210_el", "fastdds_port7413", "fastdds_port7413_el", "other_file"]
    finally:
        for f in held:
            f.close()


def test_a_missing_directory_is_nothing_to_clean(tmp_path):
    assert zombie_files(tmp_path / "absent") == [] and clean_zombie_files(tmp_path / "absent") == 0
