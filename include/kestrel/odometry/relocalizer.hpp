// Relocaliser: the pose of a frame relative to an earlier reference frame without relying on
// a good guess, for after an odometry gap (docs/flight.md, "Re-localising after an odometry
// outage").
//
// The direct alignment converges only from a guess within a few pixels of the answer; after a
// 2 s outage on a noisy IMU the guess is 20-30 cm off and the alignment stops in a wrong
// minimum (docs/flight.md, "Tried and dropped: re-tracking the pre-outage keyframe"). So the
// guess comes from features instead: keypoints matched between the two intensity images
// (within the prior's uncertainty when there is one), the reference's matches back-projected
// with its depth, and a RANSAC PnP for the relative pose. The direct tracker then refines that
// guess (its accuracy and its covariance are the odometry's), and the result is trusted only if
// both steps pass their checks and agree.
#pragma once

#include <string>

#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/geometry/se3.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/odometry/direct_tracker_options.hpp"

namespace kestrel::odometry {

/// The features matched between the two images. The office's walls are papered with discs:
/// blobs, which SIFT's difference of Gaussians finds and describes, where ORB's FAST corners
/// are few and its binary descriptors less distinct (docs/flight.md measures both).
enum class RelocalizerFeatures {
  kSift,  ///< difference-of-Gaussians blobs, SIFT descriptors (cv::SIFT)
  kOrb,   ///< FAST corners, rotated BRIEF descriptors (cv::ORB)
};

struct RelocalizerOptions {
  RelocalizerFeatures features = RelocalizerFeatures::kSift;
  /// Keypoints per image, the strongest.
  int max_features = 1000;
  /// ORB's FAST threshold (grey levels).
  int fast_threshold = 10;
  /// SIFT's contrast threshold (of the difference of Gaussians, intensities in [0, 1], divided
  /// by the octave's layers): the rendered office's walls are of low contrast, and SIFT's
  /// default of 0.04 finds 41-60 keypoints in a 376 x 240 view of them, this 247-332.
  double sift_contrast_threshold = 0.0025;
  /// Lowe's ratio test: best / second-best descriptor distance below this.
  double max_match_ratio = 0.8;
  /// Reference keypoints need a depth in this range (m), as the tracker's selection.
  double min_depth_m = 0.2;
  double max_depth_m = 6.0;
  /// RANSAC PnP: inlier threshold (px), iterations, confidence.
  double ransac_reprojection_px = 2.0;
  int ransac_iterations = 300;
  double ransac_confidence = 0.999;
  /// Checks on the PnP: at least this many inliers, and this share of the matches with depth.
  /// Few: the direct refinement and its agreement with the PnP are the real check.
  int min_inliers = 12;
  double min_inlier_ratio = 0.25;
  /// The direct refinement may move the PnP pose by at most this much: a larger change means
  /// one of the two converged wrongly (the alignment's basin is a few pixels).
  double max_refinement_translation_m = 0.05;
  double max_refinement_rotation_deg = 2.0;
  /// The refinement's bound on the motion between the frames (it replaces the tracker's
  /// health.max_translation_m, meant for consecutive frames): across a gap the camera may
  /// have moved further than between two frames.
  double max_translation_m = 1.5;

  /// Throws InputError naming the first invalid field.
  void validate() const;
};

/// Why a relocalisation was not trusted.
enum class RelocalizationFailure {
  kNone = 0,
  kInvalidInput,         ///< images of another size than the camera's, or empty
  kTooFewFeatures,       ///< too few keypoints, or matches with depth, for a PnP
  kPnpFailed,            ///< RANSAC found no pose, or too few inliers
  kOutsidePrior,         ///< the PnP pose is outside the prior's radius
  kRefinementFailed,     ///< the direct alignment from the PnP guess failed its health checks
  kRefinementDisagrees,  ///< ... or moved the pose beyond max_refinement_*
};

struct RelocalizationResult {
  RelocalizationFailure failure = RelocalizationFailure::kNone;
  [[nodiscard]] bool ok() const { return failure == RelocalizationFailure::kNone; }
  std::string detail;  ///< human-readable, empty when ok

  /// The current frame in the reference frame (the refined pose when ok), and the covariance
  /// of xi in T_ref_cur = exp(xi) * estimate, xi = [v, w] in the reference frame: the direct
  /// refinement's (TrackResult::covariance, the same model as every odometry measurement).
  SE3 T_ref_cur;
  Matrix6d covariance = Matrix6d::Identity();

  SE3 T_ref_cur_pnp;            ///< the RANSAC PnP's pose (the refinement's guess)
  int keypoints_reference = 0;  ///< keypoints found in each image
  int keypoints_current = 0;
  int matches = 0;                   ///< passing the ratio test, with a reference depth
  int inliers = 0;                   ///< of those, RANSAC PnP inliers
  double reprojection_rms_px = 0.0;  ///< of the inliers at the PnP pose
  TrackResult refinement;            ///< the direct alignment from the PnP guess
};

/// What the caller expects, and how sure it is: the search for matches is restricted to where
/// each reference point can be under it (guided matching), which keeps the ratio test from
/// discarding matches for look-alikes elsewhere in the image (the office's walls are covered in
/// similar discs). The prior's radius must cover its error: e.g. a few sigma of the IMU's
/// dead reckoning over the gap, not a guess for the alignment's basin.
struct RelocalizationPrior {
  SE3 T_ref_cur;
  double translation_radius_m = 0.3;
  double rotation_radius_deg = 3.0;
};

class Relocalizer {
 public:
  /// `camera`: the frames' camera without distortion (the flight's rectified left view);
  /// `tracker`: the direct tracker's options for the refinement (with max_translation_m as its
  /// motion bound). Throws InputError for
  /// invalid options or a camera with distortion.
  Relocalizer(const PinholeCamera& camera, const RelocalizerOptions& options,
              const DirectTrackerOptions& tracker);

  /// The pose of `current` relative to `reference` (each an intensity image with its depth;
  /// only the reference's depth is used by the PnP, both by the refinement).
  /// `prior` (may be null): restricts the matches' search and the accepted pose to its radius.
  RelocalizationResult relocalize(const RgbdFrame& reference, const RgbdFrame& current,
                                  const RelocalizationPrior* prior = nullptr);

  [[nodiscard]] const RelocalizerOptions& options() const { return options_; }

  struct Correspondences;  // matched reference points and current pixels (relocalizer.cpp)

 private:
  Correspondences match(const RgbdFrame& reference, const RgbdFrame& current,
                        const RelocalizationPrior* prior, RelocalizationResult& out) const;
  bool solve_pnp(const Correspondences& c, RelocalizationResult& out) const;

  PinholeCamera camera_;
  RelocalizerOptions options_;
  DirectTracker refiner_;
};

}  // namespace kestrel::odometry
