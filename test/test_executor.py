"""Campaign executors: an interrupted campaign or evaluation stops at once.

A plain ``with ThreadPoolExecutor`` ran every queued run of a 140-run campaign after Ctrl-C or SIGTERM
before the process could exit (seen on `rw-fdi reproduce`)."""
import threading
from contextlib import closing

import pytest

from rw_fdi_ros.tools.campaigns.campaign import LocalExecutor

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)


def test_an_interrupted_map_starts_no_queued_call():
    started, lock, release = [], threading.Lock(), threading.Event()

    def run(i):
        with lock:
            started.append(i)
        if i > 0:
            release.wait(10)   # the second worker holds here until the interruption is over
        return i

    with pytest.raises(KeyboardInterrupt):
        with closing(LocalExecutor(2).map_unordered(run, range(40))) as results:
            for _ in results:   # call 0 returns at once; the other worker holds call 1
                threading.Timer(0.2, release.set).start()
                raise KeyboardInterrupt   # Ctrl-C while the first results come in
    # only the calls already running finished: 0, 1 and what the first worker took after 0 (one more)
    assert len(started) <= 3, started


def test_a_whole_map_gives_every_result():
    assert sorted(LocalExecutor(2).map_unordered(lambda i: i * i, range(10))) == [i * i for i in range(10)]
