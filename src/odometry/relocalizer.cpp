// Relocaliser: feature matches -> RANSAC PnP on the reference's depth -> direct refinement.
#include "kestrel/odometry/relocalizer.hpp"

#include <cmath>
#include <cstdint>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"

namespace kestrel::odometry {
namespace {

void require(bool ok, const std::string& field, const std::string& why) {
  if (!ok) throw InputError("relocalizer option '" + field + "': " + why);
}

// The detectors want 8-bit grey: the tracker's inputs may be BGR, 8-bit grey or float in [0, 1].
cv::Mat to_gray8(const cv::Mat& image) {
  cv::Mat gray;
  if (image.type() == CV_8UC1) return image;
  if (image.type() == CV_8UC3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else if (image.type() == CV_32FC1) {
    image.convertTo(gray, CV_8UC1, 255.0);
  }
  return gray;
}

bool valid_frame(const RgbdFrame& f, const PinholeCamera& camera) {
  const cv::Size size(camera.width(), camera.height());
  return !f.image.empty() && f.image.size() == size && f.depth_m.size() == size &&
         f.depth_m.type() == CV_32FC1 &&
         (f.image.type() == CV_8UC1 || f.image.type() == CV_8UC3 || f.image.type() == CV_32FC1);
}

SE3 pose_from_pnp(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) Re(r, c) = R.at<double>(r, c);
  }
  const Eigen::Vector3d t(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return SE3(SO3::from_matrix(Re), t);  // T_cur_ref: reference points into the current camera
}

double rotation_deg(const SE3& T) { return T.so3().angle() * kRadToDeg; }

}  // namespace

void RelocalizerOptions::validate() const {
  require(max_features >= 50 && max_features <= 100000, "max_features", "must be in [50, 1e5]");
  require(fast_threshold >= 1 && fast_threshold <= 255, "fast_threshold", "must be in [1, 255]");
  require(sift_contrast_threshold > 0.0 && sift_contrast_threshold < 1.0, "sift_contrast_threshold",
          "must be in (0, 1)");
  require(max_match_ratio > 0.0 && max_match_ratio <= 1.0, "max_match_ratio", "must be in (0, 1]");
  require(min_depth_m > 0.0 && max_depth_m > min_depth_m, "min_depth_m/max_depth_m",
          "need 0 < min_depth_m < max_depth_m");
  require(ransac_reprojection_px > 0.0, "ransac_reprojection_px", "must be positive");
  require(ransac_iterations >= 1, "ransac_iterations", "must be >= 1");
  require(ransac_confidence > 0.0 && ransac_confidence < 1.0, "ransac_confidence",
          "must be in (0, 1)");
  require(min_inliers >= 6, "min_inliers", "must be >= 6 (a pose has 6 degrees of freedom)");
  require(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0, "min_inlier_ratio",
          "must be in [0, 1]");
  require(max_refinement_translation_m > 0.0, "max_refinement_translation_m", "must be positive");
  require(max_refinement_rotation_deg > 0.0, "max_refinement_rotation_deg", "must be positive");
  require(max_translation_m > 0.0, "max_translation_m", "must be positive");
}

namespace {

DirectTrackerOptions refinement_options(DirectTrackerOptions tracker,
                                        const RelocalizerOptions& options) {
  tracker.health.max_translation_m = options.max_translation_m;
  return tracker;
}

}  // namespace

Relocalizer::Relocalizer(const PinholeCamera& camera, const RelocalizerOptions& options,
                         const DirectTrackerOptions& tracker)
    : camera_(camera),
      options_((options.validate(), options)),
      refiner_(camera, refinement_options(tracker, options)) {
  if (camera.has_distortion()) {
    throw InputError("relocalizer: the camera must be distortion-free (rectified frames)");
  }
}

// Matches that pass the ratio test and have a reference depth: the reference's 3-D points
// and the current frame's pixels, for the PnP.
struct Relocalizer::Correspondences {
  std::vector<cv::Point3f> points_ref;
  std::vector<cv::Point2f> pixels_cur;
};

namespace {

struct Features {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
};

Features detect(const cv::Ptr<cv::Feature2D>& detector, const cv::Mat& image) {
  Features f;
  detector->detectAndCompute(to_gray8(image), cv::noArray(), f.keypoints, f.descriptors);
  return f;
}

}  // namespace

Relocalizer::Correspondences Relocalizer::match(const RgbdFrame& reference,
                                                const RgbdFrame& current,
                                                const RelocalizationPrior* prior,
                                                RelocalizationResult& out) const {
  const bool orb = options_.features == RelocalizerFeatures::kOrb;
  const int norm = orb ? cv::NORM_HAMMING : cv::NORM_L2;
  cv::Ptr<cv::Feature2D> detector;
  if (orb) {
    detector = cv::ORB::create(options_.max_features, 1.2F, 8, 31, 0, 2, cv::ORB::HARRIS_SCORE, 31,
                               options_.fast_threshold);
  } else {
    detector = cv::SIFT::create(options_.max_features, 3, options_.sift_contrast_threshold);
  }
  const Features ref = detect(detector, reference.image);
  const Features cur = detect(detector, current.image);
  out.keypoints_reference = static_cast<int>(ref.keypoints.size());
  out.keypoints_current = static_cast<int>(cur.keypoints.size());
  // The reference keypoints with a depth, their 3-D points, and (with a prior) the current
  // keypoints each may match: those where the point can be by the prior's uncertainty, its
  // translation radius at the point's predicted depth plus the rotation's. Without a prior,
  // every keypoint is a candidate.
  std::vector<int> queries;
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < static_cast<int>(ref.keypoints.size()); ++i) {
    const cv::Point2f& p = ref.keypoints[static_cast<std::size_t>(i)].pt;
    const int u = static_cast<int>(std::lround(p.x));
    const int v = static_cast<int>(std::lround(p.y));
    if (u < 0 || v < 0 || u >= camera_.width() || v >= camera_.height()) continue;
    const double z = reference.depth_m.at<float>(v, u);
    if (!std::isfinite(z) || z < options_.min_depth_m || z > options_.max_depth_m) continue;
    const Eigen::Vector3d X = camera_.unproject(Eigen::Vector2d(p.x, p.y), z);
    if (prior != nullptr && (prior->T_ref_cur.inverse() * X).z() < options_.min_depth_m) continue;
    queries.push_back(i);
    points.push_back(X);
  }
  Correspondences c;
  if (queries.empty() || cur.keypoints.empty()) {
    out.matches = 0;
    return c;
  }
  cv::Mat query_descriptors(static_cast<int>(queries.size()), ref.descriptors.cols,
                            ref.descriptors.type());
  for (std::size_t k = 0; k < queries.size(); ++k) {
    ref.descriptors.row(queries[k]).copyTo(query_descriptors.row(static_cast<int>(k)));
  }
  cv::Mat window;  // candidates per query (rows) and current keypoint (columns)
  if (prior != nullptr) {
    window = cv::Mat::zeros(query_descriptors.rows, static_cast<int>(cur.keypoints.size()), CV_8U);
    const SE3 T_cur_ref = prior->T_ref_cur.inverse();
    const double f = camera_.fx();
    for (int k = 0; k < window.rows; ++k) {
      const Eigen::Vector3d Xc = T_cur_ref * points[static_cast<std::size_t>(k)];
      const Eigen::Vector2d predicted = camera_.project(Xc);
      const double radius_px =
          f * prior->translation_radius_m / Xc.z() + f * prior->rotation_radius_deg * kDegToRad;
      for (int j = 0; j < window.cols; ++j) {
        const cv::Point2f& q = cur.keypoints[static_cast<std::size_t>(j)].pt;
        window.at<std::uint8_t>(k, j) = (Eigen::Vector2d(q.x, q.y) - predicted).norm() <= radius_px;
      }
    }
  }
  std::vector<std::vector<cv::DMatch>> knn;
  cv::BFMatcher(norm).knnMatch(query_descriptors, cur.descriptors, knn, 2, window);
  const double ratio = options_.max_match_ratio;
  for (const std::vector<cv::DMatch>& m : knn) {
    // Lowe's ratio test; a lone candidate passes (the prior's window excluded the rest).
    if (m.empty() || (m.size() == 2 && !(static_cast<double>(m[0].distance) <
                                         ratio * static_cast<double>(m[1].distance))))
      continue;
    const Eigen::Vector3d& X = points[static_cast<std::size_t>(m[0].queryIdx)];
    c.points_ref.emplace_back(static_cast<float>(X.x()), static_cast<float>(X.y()),
                              static_cast<float>(X.z()));
    c.pixels_cur.push_back(cur.keypoints[static_cast<std::size_t>(m[0].trainIdx)].pt);
  }
  out.matches = static_cast<int>(c.points_ref.size());
  return c;
}

// RANSAC PnP (EPnP on minimal sets), then Levenberg-Marquardt on the inliers. False when no
// pose passes the inlier checks; out.T_ref_cur_pnp otherwise.
bool Relocalizer::solve_pnp(const Correspondences& c, RelocalizationResult& out) const {
  const cv::Matx33d K(camera_.fx(), 0.0, camera_.cx(), 0.0, camera_.fy(), camera_.cy(), 0.0, 0.0,
                      1.0);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  const bool found = cv::solvePnPRansac(c.points_ref, c.pixels_cur, K, cv::noArray(), rvec, tvec,
                                        false, options_.ransac_iterations,
                                        static_cast<float>(options_.ransac_reprojection_px),
                                        options_.ransac_confidence, inliers, cv::SOLVEPNP_EPNP);
  out.inliers = static_cast<int>(inliers.size());
  if (!found || out.inliers < options_.min_inliers ||
      out.inliers < options_.min_inlier_ratio * out.matches) {
    std::ostringstream os;
    os << "PnP " << (found ? "found" : "found no pose") << " with " << out.inliers << " of "
       << out.matches << " matches as inliers";
    out.failure = RelocalizationFailure::kPnpFailed;
    out.detail = os.str();
    return false;
  }
  std::vector<cv::Point3f> in_points;
  std::vector<cv::Point2f> in_pixels;
  for (int i : inliers) {
    in_points.push_back(c.points_ref[static_cast<std::size_t>(i)]);
    in_pixels.push_back(c.pixels_cur[static_cast<std::size_t>(i)]);
  }
  cv::solvePnPRefineLM(in_points, in_pixels, K, cv::noArray(), rvec, tvec);
  std::vector<cv::Point2f> projected;
  cv::projectPoints(in_points, rvec, tvec, K, cv::noArray(), projected);
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < projected.size(); ++i) {
    const cv::Point2f d = projected[i] - in_pixels[i];
    sum_sq += static_cast<double>(d.dot(d));
  }
  out.reprojection_rms_px = std::sqrt(sum_sq / static_cast<double>(projected.size()));
  out.T_ref_cur_pnp = pose_from_pnp(rvec, tvec).inverse();
  return true;
}

RelocalizationResult Relocalizer::relocalize(const RgbdFrame& reference, const RgbdFrame& current,
                                             const RelocalizationPrior* prior) {
  RelocalizationResult out;
  auto fail = [&out](RelocalizationFailure why, const std::string& detail) {
    out.failure = why;
    out.detail = detail;
    return out;
  };
  if (!valid_frame(reference, camera_) || !valid_frame(current, camera_)) {
    return fail(RelocalizationFailure::kInvalidInput,
                "frames must be the camera's size: intensity (8U, 8UC3 or 32F) and 32F depth");
  }
  const Correspondences c = match(reference, current, prior, out);
  if (out.matches < options_.min_inliers) {
    std::ostringstream os;
    os << out.matches << " matches with depth (of " << out.keypoints_reference << " / "
       << out.keypoints_current << " keypoints), fewer than min_inliers " << options_.min_inliers;
    return fail(RelocalizationFailure::kTooFewFeatures, os.str());
  }
  if (!solve_pnp(c, out)) return out;
  if (prior != nullptr) {
    // A pose outside the prior's region contradicts what the matches were searched under.
    const SE3 off = prior->T_ref_cur.inverse() * out.T_ref_cur_pnp;
    if (off.translation().norm() > prior->translation_radius_m ||
        rotation_deg(off) > prior->rotation_radius_deg) {
      std::ostringstream os;
      os << "the PnP pose is " << off.translation().norm() << " m, " << rotation_deg(off)
         << " deg from the prior, outside its radius";
      return fail(RelocalizationFailure::kOutsidePrior, os.str());
    }
  }

  // The direct refinement from the PnP's guess: the odometry's accuracy and covariance, and
  // its health checks (overlap, inliers, residual) judge the pair as they judge any frame.
  out.refinement = refiner_.align_pair(reference, current, out.T_ref_cur_pnp);
  if (!out.refinement.ok()) {
    return fail(RelocalizationFailure::kRefinementFailed,
                "direct refinement: " + out.refinement.failure_detail);
  }
  const SE3 change = out.T_ref_cur_pnp.inverse() * out.refinement.T_ref_cur;
  if (change.translation().norm() > options_.max_refinement_translation_m ||
      rotation_deg(change) > options_.max_refinement_rotation_deg) {
    std::ostringstream os;
    os << "the direct refinement moved the PnP pose by " << change.translation().norm() << " m, "
       << rotation_deg(change) << " deg";
    return fail(RelocalizationFailure::kRefinementDisagrees, os.str());
  }
  out.T_ref_cur = out.refinement.T_ref_cur;
  out.covariance = out.refinement.covariance;
  return out;
}

}  // namespace kestrel::odometry
