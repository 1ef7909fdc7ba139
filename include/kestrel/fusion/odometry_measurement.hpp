// The fusion's relative-pose measurements from a stream of odometry results. Two references:
// - keyframe (the default): the motion from the keyframe the frame was aligned to, with the
//   covariance the alignment reports for exactly that motion; the filter's clone is that
//   keyframe (thesis 4.6: p_d, q_d of the last keyframe/reference frame) and moves when the
//   frame becomes the next keyframe.
// - previous frame: the motion since the last tracked frame (the difference of two
//   keyframe-relative poses, their common keyframe error cancelling) with the current frame's
//   keyframe-relative covariance; the clone moves every frame.
// docs/flight.md compares them in the closed loop.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "kestrel/fusion/fusion_engine.hpp"

namespace kestrel::fusion {

enum class OdometryReference { kKeyframe, kPreviousFrame };

/// "keyframe" / "previous_frame".
std::string_view odometry_reference_name(OdometryReference reference);
/// The inverse of odometry_reference_name(); throws std::invalid_argument listing the names.
OdometryReference parse_odometry_reference(std::string_view name);
/// The options-table hooks (io/option_fields.hpp).
inline std::string_view to_string(OdometryReference reference) {
  return odometry_reference_name(reference);
}
inline void parse_option(std::string_view name, OdometryReference& reference) {
  reference = parse_odometry_reference(name);
}

/// `Track` is odometry::TrackResult or anything with its fields (ok(), t_ns, ref_t_ns,
/// T_ref_cur, T_world_cam, covariance, new_keyframe): a template, so that fusion does not
/// depend on the odometry module. The covariance is the tracker's times `covariance_scale`
/// (its sigma^2 (J^T W J)^-1 treats the pixels as independent, docs/odometry.md).
class OdometryMeasurements {
 public:
  OdometryMeasurements(OdometryReference reference, double covariance_scale)
      : reference_(reference), covariance_scale_(covariance_scale) {}

  /// The measurement for one result, or none (a failed frame with the previous-frame
  /// reference). With the keyframe reference a failed frame, and a first frame (t_ref == t),
  /// give a clone-only measurement: the tracker restarts from that frame, so the following
  /// frames' motions start there.
  template <typename Track>
  std::optional<RelativePoseMeasurement> next(const Track& r) {
    RelativePoseMeasurement m;
    m.t_ns = r.t_ns;
    m.starts_new_reference = true;
    if (reference_ == OdometryReference::kPreviousFrame) {
      if (!r.ok()) return std::nullopt;
      if (last_) {
        m.t_ref_ns = last_->first;
        m.T_ref_cur = last_->second.inverse() * r.T_world_cam;
        m.covariance = covariance_scale_ * r.covariance;
      } else {
        clone_only(m);
      }
      last_ = std::make_pair(r.t_ns, r.T_world_cam);
      return m;
    }
    if (!r.ok() || r.ref_t_ns == r.t_ns) {
      clone_only(m);
      return m;
    }
    m.t_ref_ns = r.ref_t_ns;
    m.T_ref_cur = r.T_ref_cur;
    m.covariance = covariance_scale_ * r.covariance;
    m.starts_new_reference = r.new_keyframe;
    return m;
  }

  /// Forgets the last tracked frame (the tracker was reset).
  void reset() { last_.reset(); }

 private:
  static void clone_only(RelativePoseMeasurement& m) {
    m.t_ref_ns = m.t_ns;  // nothing to measure: the fusion only clones here
    m.covariance = Matrix6d::Identity();
  }

  OdometryReference reference_;
  double covariance_scale_;
  std::optional<std::pair<TimeNs, SE3>> last_;  // previous-frame reference: the clone's frame
};

}  // namespace kestrel::fusion
