"""Trajectory files from Python: read, write, read back unchanged; SE3 exact both ways."""

import numpy as np
import pytest

import kestrel


def test_round_trip(reference_trajectories, tmp_path):
    gt = kestrel.read_trajectory(reference_trajectories / "freiburg1_xyz-groundtruth.txt")
    assert len(gt) > 100
    assert gt.t_ns.dtype == np.int64 and gt.positions.shape == (len(gt), 3)
    assert gt.poses.shape == (len(gt), 4, 4)
    for path, write in ((tmp_path / "t.txt", kestrel.write_tum_trajectory),
                        (tmp_path / "t.csv", kestrel.write_euroc_trajectory)):
        write(path, gt)
        back = kestrel.read_trajectory(path)
        np.testing.assert_array_equal(back.t_ns, gt.t_ns)
        np.testing.assert_allclose(back.positions, gt.positions, rtol=0, atol=1e-12)
        np.testing.assert_allclose(back.quaternions_xyzw, gt.quaternions_xyzw, rtol=0, atol=1e-12)
    rebuilt = kestrel.Trajectory(gt.t_ns, gt.positions, gt.quaternions_xyzw)
    np.testing.assert_allclose(rebuilt.poses, gt.poses, rtol=0, atol=1e-12)  # renormalised
    t0, pose0 = gt[0]
    assert t0 == gt.t_ns[0] and np.array_equal(pose0.matrix(), gt.poses[0])
    assert gt[-1][0] == gt.t_ns[-1]
    with pytest.raises(IndexError):
        gt[len(gt)]


def test_refuses_to_overwrite_a_foreign_file(tmp_path):
    foreign = tmp_path / "notes.txt"
    foreign.write_text("my notes\n")
    trajectory = kestrel.Trajectory()
    trajectory.append(0, kestrel.SE3())
    with pytest.raises(kestrel.InputError, match="notes.txt"):
        kestrel.write_tum_trajectory(foreign, trajectory)
    kestrel.write_tum_trajectory(foreign, trajectory, force=True)
    assert len(kestrel.read_trajectory(foreign)) == 1


def test_se3_matrix_round_trip():
    rng = np.random.default_rng(5)
    for _ in range(20):
        T = kestrel.SE3.exp(rng.normal(size=6))
        back = kestrel.SE3.from_matrix(T.matrix())
        np.testing.assert_allclose(back.matrix(), T.matrix(), atol=1e-12)
        np.testing.assert_allclose((T * T.inverse()).matrix(), np.eye(4), atol=1e-12)
        q = T.quaternion_xyzw
        same = kestrel.SE3(T.translation, q)
        np.testing.assert_array_equal(same.quaternion_xyzw, q)
    with pytest.raises(ValueError, match="not a unit quaternion"):
        kestrel.SE3([0, 0, 0], [0, 0, 0, 2])
