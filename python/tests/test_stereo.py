"""The block matcher from Python: a textured pair shifted by a known disparity."""

import numpy as np
import pytest

import kestrel


def shifted_pair(disparity, height=96, width=160, seed=3):
    rng = np.random.default_rng(seed)
    # Texture at several scales, so that every window has structure.
    coarse = rng.integers(0, 255, (height // 4 + 1, width // 4 + 1 + disparity), dtype=np.uint8)
    left_wide = np.repeat(np.repeat(coarse, 4, axis=0), 4, axis=1)[:height].astype(np.int16)
    left_wide += rng.integers(-20, 20, left_wide.shape, dtype=np.int16)
    left_wide = np.clip(left_wide, 0, 255).astype(np.uint8)
    left = np.ascontiguousarray(left_wide[:, :width])
    right = np.ascontiguousarray(left_wide[:, disparity:disparity + width])  # uR = uL - d
    return left, right


@pytest.mark.parametrize("disparity", [5, 12])
def test_matcher_finds_the_shift(disparity):
    left, right = shifted_pair(disparity)
    matcher = kestrel.BlockMatcher(block_size=9, max_disparity=32)
    d, stats = matcher.match(left, right)
    assert d.dtype == np.float32 and d.shape == left.shape
    valid = np.isfinite(d)
    assert stats.pixels == d.size and stats.valid == int(valid.sum())
    assert stats.fill_rate > 0.5
    inner = d[10:-10, 40:-10]
    inner = inner[np.isfinite(inner)]
    assert abs(float(np.median(inner)) - disparity) < 0.25
    assert np.mean(np.abs(inner - disparity) < 1.0) > 0.9


def test_matcher_options_are_validated():
    with pytest.raises(ValueError, match="block_size"):
        kestrel.BlockMatcher(block_size=4)
    assert "max_disparity: 48" in kestrel.BlockMatcher(max_disparity=48).options_yaml
