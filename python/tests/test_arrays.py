"""numpy in and out: arrays of the wrong dtype, shape or layout raise ValueError saying what
was expected; good arrays are read in place, and outputs share the C++ buffer."""

import numpy as np
import pytest

import kestrel

H, W = 48, 64


@pytest.fixture()
def tracker():
    return kestrel.Tracker("fr1")


def good_frame():
    rng = np.random.default_rng(1)
    bgr = rng.integers(0, 255, (H, W, 3), dtype=np.uint8)
    depth = np.full((H, W), 1.5, dtype=np.float32)
    return bgr, depth


@pytest.mark.parametrize("image, message", [
    (np.zeros((H, W, 3), np.float64), "got dtype float64"),
    (np.zeros((H, W, 4), np.uint8), "shape (48, 64, 4)"),
    (np.zeros((H * W,), np.uint8), "shape (3072,)"),
    (np.zeros((H, W), np.int32), "got dtype int32"),
])
def test_bad_image_raises_value_error(tracker, image, message):
    _, depth = good_frame()
    with pytest.raises(ValueError, match=r"^image: expected uint8 \(H, W, 3\)") as error:
        tracker.track(0, image, depth)
    assert message in str(error.value)


def test_non_contiguous_image_raises_value_error(tracker):
    bgr, depth = good_frame()
    wide = np.zeros((H, 2 * W, 3), np.uint8)
    with pytest.raises(ValueError, match="image: the array must be C-contiguous"):
        tracker.track(0, wide[:, ::2], depth)
    with pytest.raises(ValueError, match="depth_m: the array must be C-contiguous"):
        tracker.track(0, bgr, np.asfortranarray(np.zeros((H, W), np.float32)))


def test_bad_depth_raises_value_error(tracker):
    bgr, depth = good_frame()
    with pytest.raises(ValueError, match=r"depth_m: expected float32 \(H, W\), got dtype float64"):
        tracker.track(0, bgr, depth.astype(np.float64))
    with pytest.raises(ValueError, match=r"depth_m: shape \(24, 64\) differs from the image's"):
        tracker.track(0, bgr, depth[: H // 2].copy())


def test_good_arrays_are_accepted_read_only_too(tracker):
    bgr, depth = good_frame()
    bgr.flags.writeable = False
    result = tracker.track(0, bgr, depth)
    assert np.array_equal(result.pose, np.eye(4))  # the first frame defines the world
    grey = np.ascontiguousarray(bgr[:, :, 1])
    assert tracker.track(33_000_000, grey, depth).t_ns == 33_000_000


def test_matcher_checks_both_images():
    matcher = kestrel.BlockMatcher(max_disparity=32)
    left = np.zeros((H, W), np.uint8)
    with pytest.raises(ValueError, match="right: expected uint8 .* got dtype uint16"):
        matcher.match(left, np.zeros((H, W), np.uint16))
    with pytest.raises(ValueError, match="right: shape and dtype must equal the left image's"):
        matcher.match(left, np.zeros((H, W - 1), np.uint8))
    with pytest.raises(ValueError, match="left: the array must be C-contiguous"):
        matcher.match(np.zeros((W, H), np.uint8).T, left)


def test_trajectory_arrays_are_checked():
    t = np.arange(3, dtype=np.int64)
    p = np.zeros((3, 3))
    q = np.tile([0.0, 0.0, 0.0, 1.0], (3, 1))
    assert len(kestrel.Trajectory(t, p, q)) == 3
    with pytest.raises(ValueError, match=r"quaternions_xyzw: expected float64 \(3, 4\)"):
        kestrel.Trajectory(t, p, q[:, :3].copy())
    with pytest.raises(ValueError, match=r"t_ns: expected int64 \(3,\), got dtype float64"):
        kestrel.Trajectory(t.astype(np.float64), p, q)
    with pytest.raises(ValueError, match="row 1 is not a unit quaternion"):
        q2 = q.copy()
        q2[1] = [0.0, 0.0, 0.0, 2.0]
        kestrel.Trajectory(t, p, q2)


def test_decoded_frames_share_the_cpp_buffer(rpy_folder):
    t_ns, bgr, depth = kestrel.TumSequence(rpy_folder)[0]
    assert bgr.dtype == np.uint8 and bgr.shape == (480, 640, 3)
    assert depth.dtype == np.float32 and depth.shape == (480, 640)
    assert not bgr.flags.owndata and not depth.flags.owndata  # owned by the cv::Mat
    assert bgr.flags.c_contiguous and depth.flags.c_contiguous
    assert t_ns > 0 and np.nanmax(depth) > 0.5
