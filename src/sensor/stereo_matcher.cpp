// The stereo matcher choice: a name per mode and a variant of the two matchers.
#include "kestrel/sensor/stereo_matcher.hpp"

#include <stdexcept>
#include <string>

namespace kestrel::sensor {
namespace {

std::variant<BlockMatcher, SgmMatcher> make(StereoMatcherKind kind, BlockMatcherOptions block,
                                            const SgmOptions& sgm,
                                            const std::optional<RectifiedStereo>& rig) {
  if (kind == StereoMatcherKind::kSgm) return SgmMatcher(sgm);
  block.cost = kind == StereoMatcherKind::kCensus ? MatchingCost::kCensus : MatchingCost::kSad;
  return BlockMatcher(block, rig);
}

}  // namespace

std::string_view to_string(StereoMatcherKind kind) {
  switch (kind) {
    case StereoMatcherKind::kSad:
      return "sad";
    case StereoMatcherKind::kCensus:
      return "census";
    case StereoMatcherKind::kSgm:
      return "sgm";
  }
  return "?";
}

void parse_option(std::string_view name, StereoMatcherKind& kind) {
  if (name == "sad") {
    kind = StereoMatcherKind::kSad;
  } else if (name == "census") {
    kind = StereoMatcherKind::kCensus;
  } else if (name == "sgm") {
    kind = StereoMatcherKind::kSgm;
  } else {
    throw std::invalid_argument("must be sad, census or sgm, got '" + std::string(name) + "'");
  }
}

StereoMatcher::StereoMatcher(StereoMatcherKind kind, BlockMatcherOptions block,
                             const SgmOptions& sgm, const std::optional<RectifiedStereo>& rig)
    : kind_(kind), matcher_(make(kind, block, sgm, rig)) {}

std::string StereoMatcher::describe() const {
  if (const auto* s = std::get_if<SgmMatcher>(&matcher_)) return s->options().describe();
  return std::get<BlockMatcher>(matcher_).options().describe();
}

MatchStats StereoMatcher::match(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity) {
  return std::visit([&](auto& m) { return m.match(left, right, disparity); }, matcher_);
}

}  // namespace kestrel::sensor
