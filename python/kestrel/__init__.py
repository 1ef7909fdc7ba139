"""Kestrel: on-board direct visual odometry for micro aerial vehicles, from Python.

The tracker (:class:`Tracker`), the stereo block matcher (:class:`BlockMatcher`), the IMU +
odometry EKF (:class:`Fusion`), trajectory files (:func:`read_trajectory`,
:func:`write_tum_trajectory`), TUM RGB-D folders (:class:`TumSequence`) and the evaluation
(:func:`evaluate`). Images are numpy arrays read in place (C-contiguous uint8 BGR or grey,
float32 depth in metres); poses are :class:`SE3` objects or 4x4 float64 arrays; times are
int64 nanoseconds. Long calls release the GIL. See docs/api.md.
"""

from ._kestrel import (
    BlockMatcher,
    Evaluation,
    FusedState,
    Fusion,
    InputError,
    MatchStats,
    SE3,
    TrackResult,
    Tracker,
    Trajectory,
    TumSequence,
    evaluate,
    read_trajectory,
    write_euroc_trajectory,
    write_tum_trajectory,
)

__all__ = [
    "BlockMatcher",
    "Evaluation",
    "FusedState",
    "Fusion",
    "InputError",
    "MatchStats",
    "SE3",
    "TrackResult",
    "Tracker",
    "Trajectory",
    "TumSequence",
    "evaluate",
    "read_trajectory",
    "write_euroc_trajectory",
    "write_tum_trajectory",
]
