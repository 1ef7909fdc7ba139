// The choice of stereo matcher, one name per mode: `sad` (the fast block matcher), `census` (the
// block matcher on census costs) or `sgm` (the semi-global matcher, the quality mode). The stereo
// front end, and through it the pipeline, the flight and the ROS node, match through this.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/sgm_matcher.hpp"

namespace kestrel::sensor {

enum class StereoMatcherKind {
  kSad,     ///< BlockMatcher, SAD cost
  kCensus,  ///< BlockMatcher, census cost
  kSgm,     ///< SgmMatcher
};

/// "sad" / "census" / "sgm": the names in option files and on the command line.
[[nodiscard]] std::string_view to_string(StereoMatcherKind kind);
/// The options-table hook; throws std::invalid_argument listing the names.
void parse_option(std::string_view name, StereoMatcherKind& kind);

/// One of the matchers, chosen at construction.
class StereoMatcher {
 public:
  /// `block` is used for sad and census (its cost is set from the kind), `sgm` for sgm; the
  /// rig only by the block matcher's depth range. Throws std::invalid_argument for invalid
  /// options.
  StereoMatcher(StereoMatcherKind kind, BlockMatcherOptions block, const SgmOptions& sgm,
                const std::optional<RectifiedStereo>& rig = std::nullopt);

  [[nodiscard]] StereoMatcherKind kind() const { return kind_; }
  /// The chosen matcher's options, one line.
  [[nodiscard]] std::string describe() const;
  /// As BlockMatcher::match / SgmMatcher::match.
  MatchStats match(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity);

 private:
  StereoMatcherKind kind_;
  std::variant<BlockMatcher, SgmMatcher> matcher_;
};

}  // namespace kestrel::sensor
