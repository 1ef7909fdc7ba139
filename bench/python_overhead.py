#!/usr/bin/env python3
"""What the Python path costs per frame over the C++ path (docs/api.md, "Python overhead").

Tracks a TUM folder (default: the dev sequence fr1/rpy) with kestrel.Tracker and times, per
frame, the Python call tracker.track() plus reading result.pose and result.covariance (numpy
checks, GIL release, result conversion) against the C++ tracking time inside that call
(tracker.last_track_s), and against `kestrel odometry`'s own mean per-frame time (its SUMMARY
line) when the CLI is given. Decoding is excluded from both, as the CLI excludes it; the first
frame (no alignment) too. Each figure is the best mean of --repeats passes; the same-process
figure is the binding's own cost, the CLI comparison adds the noise of separate runs.

  PYTHONPATH=build/release/python python3 bench/python_overhead.py \
      --kestrel build/release/kestrel [FOLDER]
"""

import argparse
import pathlib
import re
import statistics
import subprocess
import sys
import tempfile
import time

import kestrel


def python_pass(tracker, sequence):
    """Decodes each frame just before tracking it, as the CLI does (frames decoded all ahead
    are cold in the cache: that costs the C++ tracker ~40 % more per frame, Python or not)."""
    tracker.reset()
    call_s, cpp_s = [], []
    for i in range(len(sequence)):
        t_ns, bgr, depth = sequence[i]
        begin = time.perf_counter()
        result = tracker.track(t_ns, bgr, depth)
        _ = result.pose, result.covariance
        elapsed = time.perf_counter() - begin
        if i > 0:
            call_s.append(elapsed)
            cpp_s.append(tracker.last_track_s)
    return statistics.mean(call_s), statistics.mean(cpp_s)


def cli_mean_s(binary, folder):
    with tempfile.TemporaryDirectory() as tmp:
        run = subprocess.run([binary, "odometry", str(folder), "--out", f"{tmp}/t.txt"],
                             capture_output=True, text=True, check=True)
    match = re.search(r"SUMMARY frames=\d+ failures=\d+ mean_ms=([0-9.]+)", run.stderr)
    return float(match.group(1)) / 1e3


def main():
    here = pathlib.Path(__file__).resolve().parents[1]
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?",
                        default=here / ".." / "shared" / "data" / "tum" /
                        "rgbd_dataset_freiburg1_rpy_part1")
    parser.add_argument("--camera", default="fr1")
    parser.add_argument("--kestrel", help="the kestrel CLI, for its per-frame time")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    sequence = kestrel.TumSequence(args.folder)
    tracker = kestrel.Tracker(args.camera)
    passes, cli_passes = [], []
    for _ in range(args.repeats):  # interleaved, so that both see the same machine load
        passes.append(python_pass(tracker, sequence))
        if args.kestrel:
            cli_passes.append(cli_mean_s(args.kestrel, args.folder))
    call = min(p[0] for p in passes)
    cpp = min(p[1] for p in passes)
    print(f"frames: {len(sequence)} of {args.folder}, best of {args.repeats} passes")
    print(f"python tracker.track() + pose/covariance: {call * 1e3:.3f} ms per frame")
    print(f"C++ DirectTracker::track inside it:       {cpp * 1e3:.3f} ms per frame")
    print(f"python overhead over C++ (same process):  {(call - cpp) * 1e6:.1f} us, "
          f"{100 * (call - cpp) / cpp:.2f} %")
    if cli_passes:
        cli = min(cli_passes)
        print(f"kestrel odometry (CLI) mean:              {cli * 1e3:.3f} ms per frame")
        print(f"python over the CLI:                      {100 * (call - cli) / cli:+.2f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
