"""The EKF from Python: a vehicle at rest stays at rest, and the batch IMU input is the same
filter as one sample at a time."""

import numpy as np

import kestrel

G = 9.81


def still_imu(seconds=3.0, rate_hz=200.0, seed=7):
    n = int(seconds * rate_hz)
    rng = np.random.default_rng(seed)
    t_ns = (np.arange(n) * (1e9 / rate_hz)).astype(np.int64) + 1_000_000_000
    gyro = rng.normal(0.0, 1e-3, (n, 3))
    accel = rng.normal(0.0, 1e-2, (n, 3)) + [0.0, 0.0, G]  # specific force at rest: +g up
    return t_ns, gyro, accel


def run(batch):
    t_ns, gyro, accel = still_imu()
    fusion = kestrel.Fusion()
    if batch:
        fusion.add_imu_batch(t_ns, gyro, accel)
    else:
        for t, g, a in zip(t_ns, gyro, accel):
            fusion.add_imu(int(t), g, a)
    # The odometry sees no motion: identity relative poses every 50 ms after the still start.
    covariance = np.eye(6) * 1e-6
    previous = None
    for t in t_ns[::10]:
        if previous is not None and t > t_ns[0] + 1_200_000_000:
            fusion.add_relative_pose(int(previous), int(t), kestrel.SE3(), covariance)
        previous = t
    return fusion, fusion.flush(imu_rate=False)


def test_still_vehicle_stays_still():
    fusion, states = run(batch=True)
    assert fusion.initialized
    assert fusion.updates_accepted > 20
    assert len(states) > 20 and all(s.at_odometry for s in states)
    for s in states:
        assert np.linalg.norm(s.p_world) < 0.01, s.p_world
        assert np.linalg.norm(s.v_world) < 0.02, s.v_world
        assert s.pose.shape == (4, 4) and s.sigma.shape == (9,)
        assert np.all(s.sigma > 0)


def test_batch_equals_one_at_a_time():
    _, batch = run(batch=True)
    _, single = run(batch=False)
    assert len(batch) == len(single)
    for a, b in zip(batch, single):
        assert a.t_ns == b.t_ns
        np.testing.assert_array_equal(a.pose, b.pose)
        np.testing.assert_array_equal(a.sigma, b.sigma)
