"""The Python tracker on the dev sequence gives the trajectory `kestrel odometry` writes,
to the last digit: same frames, same tracker, same options, no copies on the way in."""

import subprocess

import numpy as np

import kestrel


def data_lines(path):
    return [line for line in path.read_text().splitlines() if not line.startswith("#")]


def test_python_tracker_equals_cli(rpy_folder, kestrel_binary, tmp_path):
    cli_out = tmp_path / "cli.txt"
    subprocess.run(
        [str(kestrel_binary), "odometry", str(rpy_folder), "--out", str(cli_out)],
        check=True, capture_output=True, text=True)

    tracker = kestrel.Tracker("fr1")
    sequence = kestrel.TumSequence(rpy_folder, depth_scale=tracker.depth_scale or 5000.0)
    trajectory = kestrel.Trajectory()
    ok = 0
    for i in range(len(sequence)):
        t_ns, bgr, depth_m = sequence[i]
        result = tracker.track(t_ns, bgr, depth_m)
        assert result.t_ns == t_ns
        assert result.pose.shape == (4, 4) and result.covariance.shape == (6, 6)
        np.testing.assert_array_equal(result.pose, result.T_world_cam.matrix())
        ok += result.ok
        trajectory.append(t_ns, result.T_world_cam)
    py_out = tmp_path / "python.txt"
    kestrel.write_tum_trajectory(py_out, trajectory)

    cli_lines, py_lines = data_lines(cli_out), data_lines(py_out)
    assert len(py_lines) == len(sequence) > 100
    assert ok > len(sequence) // 2, "the tracker should track most of fr1/rpy"
    mismatches = [i for i, (a, b) in enumerate(zip(cli_lines, py_lines)) if a != b]
    assert len(cli_lines) == len(py_lines)
    assert not mismatches, f"{len(mismatches)} poses differ, first at line {mismatches[0]}: " \
                           f"{cli_lines[mismatches[0]]!r} vs {py_lines[mismatches[0]]!r}"
    # And read back: the same numbers, not only the same text.
    a, b = kestrel.read_trajectory(cli_out), kestrel.read_trajectory(py_out)
    np.testing.assert_array_equal(a.t_ns, b.t_ns)
    np.testing.assert_array_equal(a.poses, b.poses)
