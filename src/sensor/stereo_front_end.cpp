// The stereo front end: rectification -> stereo matching -> disparity (and depth).
#include "kestrel/sensor/stereo_front_end.hpp"

#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "kestrel/core/error.hpp"
#include "kestrel/core/stopwatch.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::sensor {

namespace {

StereoMatcher make_matcher(const StereoFrontEndOptions& options, const RectifiedStereo& rig) {
  const BlockMatcherOptions& block = options.matcher;
  const StereoMatcherKind kind = options.kind.value_or(
      block.cost == MatchingCost::kCensus ? StereoMatcherKind::kCensus : StereoMatcherKind::kSad);
  SgmOptions sgm = options.sgm;
  sgm.min_disparity = block.min_disparity;
  sgm.max_disparity = block.max_disparity;
  try {
    return StereoMatcher(kind, block, sgm, rig);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("stereo matcher (") + std::string(to_string(kind)) +
                     "): " + e.what());
  }
}

// The value a matcher file gives `key`, if it names it (the defaults are no contradiction).
std::optional<std::string> named_value(const std::filesystem::path& file, const char* key,
                                       const char* what) {
  const YAML::Node node = io::load_yaml_map(file, what)[key];
  if (!node || !node.IsScalar()) return std::nullopt;
  return node.as<std::string>();
}

}  // namespace

void apply_matcher_selection(const MatcherSelection& selection, const std::string& source,
                             StereoFrontEndOptions& options, const MatcherSelection::Keys& keys) {
  options.matcher = selection.block_file.empty()
                        ? BlockMatcherOptions{}
                        : BlockMatcherOptions::load_yaml(selection.block_file);
  options.kind = selection.kind;
  const BlockMatcherOptions& block = options.matcher;
  if (selection.kind && *selection.kind != StereoMatcherKind::kSgm &&
      !selection.block_file.empty()) {
    const std::string wanted(to_string(*selection.kind));
    const auto cost = named_value(selection.block_file, "cost", "block matcher");
    if (cost && *cost != wanted) {
      throw InputError(source, keys.kind,
                       wanted + " contradicts the cost '" + *cost + "' of " + keys.block_file +
                           " " + selection.block_file.string() + " (give one of them)");
    }
  }
  options.sgm = SgmOptions{};
  if (selection.sgm_file.empty()) return;
  if (selection.kind != StereoMatcherKind::kSgm) {
    const std::string kind(selection.kind ? to_string(*selection.kind)
                                          : "unset (the block matcher)");
    throw InputError(source, keys.sgm_file,
                     "is for " + keys.kind + ": sgm (here " + keys.kind + " is " + kind + ")");
  }
  options.sgm = SgmOptions::load_yaml(selection.sgm_file);
  // The range is the block matcher's (StereoFrontEndOptions): a file that sets another one
  // would be silently overridden.
  for (const auto& [key, used] : {std::pair{"min_disparity", block.min_disparity},
                                  std::pair{"max_disparity", block.max_disparity}}) {
    const int given =
        key == std::string("min_disparity") ? options.sgm.min_disparity : options.sgm.max_disparity;
    if (named_value(selection.sgm_file, key, "semi-global matcher") && given != used) {
      throw InputError(selection.sgm_file, key,
                       std::to_string(given) + " differs from the range in use (" +
                           std::to_string(used) + ", the block matcher's " + key + " of " +
                           (selection.block_file.empty()
                                ? std::string("its defaults")
                                : keys.block_file + " " + selection.block_file.string()) +
                           "): every matcher searches that range; set it there");
    }
  }
}

StereoFrontEnd::StereoFrontEnd(const StereoCalibration& calibration,
                               const StereoFrontEndOptions& options)
    : options_(options),
      rectifier_(std::in_place, calibration, options.rectify),
      rig_(rectifier_->rig()),
      matcher_(make_matcher(options, rig_)) {}

StereoFrontEnd::StereoFrontEnd(const RectifiedStereo& rig, const StereoFrontEndOptions& options)
    : options_(options), rig_(rig), matcher_(make_matcher(options, rig)) {}

Eigen::Matrix3d StereoFrontEnd::R_rect_left() const {
  return rectifier_ ? rectifier_->R_rect_left() : Eigen::Matrix3d::Identity();
}

void StereoFrontEnd::process(TimeNs t_ns, const cv::Mat& left, const cv::Mat& right,
                             StereoDepthFrame& out) {
  out.t_ns = t_ns;
  auto start = std::chrono::steady_clock::now();
  if (rectifier_) {
    rectifier_->rectify(left, right, out.left_rect, out.right_rect);
  } else {
    out.left_rect = left;  // headers: no copy
    out.right_rect = right;
  }
  out.rectify_ms = ms_since(start);

  start = std::chrono::steady_clock::now();
  out.match = matcher_.match(out.left_rect, out.right_rect, out.disparity_px);
  if (options_.compute_depth) {
    disparity_to_depth(out.disparity_px, rig_, out.depth_m);
  } else {
    out.depth_m.release();
  }
  out.match_ms = ms_since(start);
}

}  // namespace kestrel::sensor
