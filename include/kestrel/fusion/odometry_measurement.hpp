// The fusion's relative-pose measurement from one odometry result, keyframe-relative: the
// motion from the keyframe the frame was aligned to, with the covariance the alignment
// reports for exactly that motion. The filter's clone is that keyframe (thesis 4.6: p_d, q_d
// of the last keyframe/reference frame) and moves when the frame becomes the next keyframe.
#pragma once

#include "kestrel/fusion/fusion_engine.hpp"

namespace kestrel::fusion {

/// `Track` is odometry::TrackResult or anything with its fields (ok(), t_ns, ref_t_ns,
/// T_ref_cur, covariance, new_keyframe); a template so that fusion does not depend on the
/// odometry module. A failed frame, and a first frame (t_ref == t), give a clone-only
/// measurement: the tracker restarts from that frame, so the following frames' motions start
/// there. The covariance is the tracker's times `covariance_scale` (its sigma^2 (J^T W J)^-1
/// treats the pixels as independent, docs/odometry.md).
template <typename Track>
RelativePoseMeasurement keyframe_measurement(const Track& r, double covariance_scale) {
  RelativePoseMeasurement m;
  m.t_ns = r.t_ns;
  m.starts_new_reference = true;
  if (!r.ok() || r.ref_t_ns == r.t_ns) {
    m.t_ref_ns = r.t_ns;  // nothing to measure: the fusion only clones here
    m.covariance = Matrix6d::Identity();
    return m;
  }
  m.t_ref_ns = r.ref_t_ns;
  m.T_ref_cur = r.T_ref_cur;
  m.covariance = covariance_scale * r.covariance;
  m.starts_new_reference = r.new_keyframe;
  return m;
}

}  // namespace kestrel::fusion
