"""Long calls release the GIL: a Python thread keeps running while C++ matches."""

import sys
import threading
import time

import numpy as np

import kestrel


def count_during(call):
    """How often a Python thread increments a counter while `call` runs on this thread.

    With a long switch interval the interpreter never takes the GIL from this thread while it
    is inside C++: the counter moves only if the call releases the GIL itself."""
    count = 0
    stop = threading.Event()
    started = threading.Event()

    def spin():
        nonlocal count
        started.set()
        while not stop.is_set():
            count += 1

    interval = sys.getswitchinterval()
    sys.setswitchinterval(0.1)
    try:
        worker = threading.Thread(target=spin)
        worker.start()
        started.wait()
        before = count
        begin = time.perf_counter()
        call()
        elapsed = time.perf_counter() - begin
        during = count - before
        stop.set()
        worker.join()
    finally:
        sys.setswitchinterval(interval)
    return during, elapsed


def test_matcher_releases_the_gil():
    rng = np.random.default_rng(2)
    left = rng.integers(0, 255, (960, 1280), dtype=np.uint8)
    right = np.ascontiguousarray(np.roll(left, -8, axis=1))
    matcher = kestrel.BlockMatcher(max_disparity=128)
    during, elapsed = count_during(lambda: matcher.match(left, right))
    assert elapsed > 0.005, "the call is too short to tell"
    assert during > 100, f"{during} increments in {elapsed:.3f} s"
