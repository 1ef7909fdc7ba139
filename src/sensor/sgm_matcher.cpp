// Semi-global matching (Hirschmueller, PAMI 2008) on one core. Two passes over the image: the
// top-down pass runs the paths that come from the left, the top-left, the top and the top-right
// (4 paths: left and top) and stores their sum per pixel and disparity; the bottom-up pass runs
// the other half, adds the stored sums and decides each row as soon as it is complete. Only the
// previous row's path costs are kept per vertical path (Spangenberg et al., IV 2014), so the one
// large buffer is the top-down sums. The row kernels are in sgm_kernels.hpp.
#include "kestrel/sensor/sgm_matcher.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "grey_input.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"
#include "sgm_kernels.hpp"

namespace kestrel::sensor {
namespace {

using sgm::kSgmGuard;
using sgm::kSgmMaskedCost;
using sgm::kSgmMaxVectorLanes;

}  // namespace

std::string_view to_string(CensusPattern pattern) {
  return pattern == CensusPattern::kFull ? "full" : "center_symmetric";
}

void parse_option(std::string_view name, CensusPattern& pattern) {
  if (name == "full") {
    pattern = CensusPattern::kFull;
  } else if (name == "center_symmetric") {
    pattern = CensusPattern::kCenterSymmetric;
  } else {
    throw std::invalid_argument("must be full or center_symmetric, got '" + std::string(name) +
                                "'");
  }
}

int SgmOptions::census_bits() const {
  const int area = census_width * census_height;
  return census == CensusPattern::kFull ? area - 1 : (area - 1) / 2;
}

void SgmOptions::validate() const {
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("semi-global matcher: " + what);
  };
  const auto str = [](auto v) { return std::to_string(v); };
  if (min_disparity < 0) fail("min_disparity must be >= 0, got " + str(min_disparity));
  if (max_disparity <= min_disparity) {
    fail("the disparity range is empty: max_disparity (" + str(max_disparity) +
         ") must exceed min_disparity (" + str(min_disparity) + ")");
  }
  if (max_disparity - min_disparity > 512) fail("at most 512 disparities are searched");
  for (const auto& [name, side] :
       {std::pair{"census_width", census_width}, std::pair{"census_height", census_height}}) {
    if (side < 1 || side > 15 || side % 2 == 0) {
      fail(std::string(name) + " must be odd, in [1, 15], got " + str(side));
    }
  }
  if (census_bits() < 1 || census_bits() > 32) {
    fail("the census signature has " + str(census_bits()) + " bits (" + str(census_width) + "x" +
         str(census_height) + " " + std::string(to_string(census)) + "); it must have 1 to 32");
  }
  if (p1 < 1) fail("p1 must be >= 1, got " + str(p1));
  if (p2 < p1) fail("p2 (" + str(p2) + ") must be >= p1 (" + str(p1) + ")");
  if (p2 > 4096) fail("p2 must be <= 4096, got " + str(p2));
  if (p2_gradient < 0 || p2_gradient > 255) {
    fail("p2_gradient must lie in [0, 255] grey levels (0: constant P2), got " + str(p2_gradient));
  }
  if (paths != 4 && paths != 8) fail("paths must be 4 or 8, got " + str(paths));
  if (paths * (census_bits() + p2) >= kSgmMaskedCost) {
    fail("paths * (census bits + p2) must stay below 65535 (uint16 sums)");
  }
  if (lr_max_diff > 16) fail("lr_max_diff must be <= 16 (or negative: off)");
  if (speckle_size < 0) fail("speckle_size must be >= 0 (0: off), got " + str(speckle_size));
  if (!(speckle_max_diff > 0.0) || !std::isfinite(speckle_max_diff)) {
    fail("speckle_max_diff must be a positive number of pixels");
  }
}

std::string SgmOptions::describe() const {
  std::ostringstream os;
  os << "sgm disparity=[" << min_disparity << "," << max_disparity << ") census=" << census_width
     << "x" << census_height << " " << to_string(census) << " p1=" << p1 << " p2=" << p2
     << " p2_gradient=" << p2_gradient << " paths=" << paths
     << " subpixel=" << (subpixel ? "on" : "off") << " lr_max_diff=" << lr_max_diff
     << " median=" << (median ? "3x3" : "off") << " speckle=" << speckle_size << "("
     << speckle_max_diff << " px)";
  return os.str();
}

std::string SgmOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

SgmOptions SgmOptions::load_yaml(const std::filesystem::path& path) {
  SgmOptions o;
  io::option_fields::read_fields(io::load_yaml_map(path, "semi-global matcher"), path.string(),
                                 "semi-global matcher", o);
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(path.string() + ": " + e.what());
  }
  return o;
}

// ---------------------------------------------------------------------------------------------
// Matcher

SgmMatcher::SgmMatcher(SgmOptions options) : options_(options) { options_.validate(); }

const char* SgmMatcher::simd_target() { return sgm::simd_target(); }
std::vector<std::int64_t> SgmMatcher::simd_targets() { return sgm::simd_targets(); }

bool SgmMatcher::runs_8bit_paths() const {
  // Every path cost is at most the largest matching cost (the census bits; the neutral cost is
  // half of them) plus the largest P2 (p2_lut's entries are at most max(p1, p2) = p2).
  return allow_8bit_ && !reference_ && sgm::simd_kernels().aggregate_row8 != nullptr &&
         options_.census_bits() + options_.p2 <= sgm::kSgmMax8BitCostPlusP2;
}

void SgmMatcher::prepare(int width, int height) {
  if (width == width_ && height == height_) return;
  width_ = width;
  height_ = height;
  range_ = options_.max_disparity - options_.min_disparity;
  lanes_ = (range_ + kSgmMaxVectorLanes - 1) / kSgmMaxVectorLanes * kSgmMaxVectorLanes;
  const auto w = static_cast<std::size_t>(width), h = static_cast<std::size_t>(height);
  const auto lanes = static_cast<std::size_t>(lanes_);
  const std::size_t census_row = w + kSgmMaxVectorLanes;
  for (auto* v : {&census_l_lo_, &census_l_hi_, &census_r_lo_, &census_r_hi_}) {
    v->assign(h * census_row, 0);
  }
  const std::size_t rev = w + static_cast<std::size_t>(options_.min_disparity) + lanes;
  rev_lo_.assign(rev, 0);
  rev_hi_.assign(rev, 0);
  pad_mask_.assign(lanes, 0);
  for (int k = range_; k < lanes_; ++k) pad_mask_[static_cast<std::size_t>(k)] = kSgmMaskedCost;
  cost_.assign(w * lanes, 0);
  volume_.assign(h * w * lanes, 0);
  total_.assign(w * lanes, 0);
  const std::size_t slots = (w + 2) * (lanes + kSgmGuard);
  rows_.assign(6 * slots, kSgmMaskedCost);
  row_min_.assign(6 * (w + 2), kSgmMaskedCost);
  horizontal_.assign(3 * (lanes + kSgmGuard), kSgmMaskedCost);
  best_.assign(w, 0);
  best_cost_.assign(w, 0);
  p2_row_.assign(4 * w, 0);
  rejected_.assign(w * h, 0);
  right_min_rev_.assign(w + lanes, kSgmMaskedCost);
}

// The census pairs as element offsets in the padded image (stride known only here).
void SgmMatcher::census(const cv::Mat& gray, std::vector<std::uint16_t>& low,
                        std::vector<std::uint16_t>& high) {
  const int rx = options_.census_width / 2, ry = options_.census_height / 2;
  cv::copyMakeBorder(gray, padded_, ry, ry, rx, rx + kSgmMaxVectorLanes, cv::BORDER_REPLICATE);
  const auto stride = static_cast<std::int32_t>(padded_.step[0]);
  offset_a_.clear();
  offset_b_.clear();
  for (int dy = -ry; dy <= ry; ++dy) {
    for (int dx = -rx; dx <= rx; ++dx) {
      const std::int32_t o = dy * stride + dx;
      if (options_.census == CensusPattern::kFull && o != 0) {
        offset_a_.push_back(0);
        offset_b_.push_back(o);
      } else if (options_.census == CensusPattern::kCenterSymmetric && o < 0) {
        offset_a_.push_back(o);  // one of each mirrored pair: the half before the centre
        offset_b_.push_back(-o);
      }
    }
  }
  const sgm::Kernels& k = reference_ ? sgm::reference_kernels() : sgm::simd_kernels();
  const std::size_t row = static_cast<std::size_t>(width_) + kSgmMaxVectorLanes;
  for (int y = 0; y < height_; ++y) {
    sgm::CensusRowArgs a;
    a.center = padded_.ptr<std::uint8_t>(y + ry) + rx;
    a.offset_a = offset_a_.data();
    a.offset_b = offset_b_.data();
    a.bits = static_cast<int>(offset_a_.size());
    a.width = width_;
    a.low = low.data() + static_cast<std::size_t>(y) * row;
    a.high = high.data() + static_cast<std::size_t>(y) * row;
    k.census_row(a);
  }
}

// Matching costs of row y; lanes whose right pixel lies left of the image get a neutral cost
// (half the census bits: what an unrelated pair of signatures costs on average), so that the
// paths, not the border, decide those disparities.
void SgmMatcher::cost_row(int y) {
  const std::size_t row = static_cast<std::size_t>(width_) + kSgmMaxVectorLanes;
  const std::uint16_t* r_lo = census_r_lo_.data() + static_cast<std::size_t>(y) * row;
  const std::uint16_t* r_hi = census_r_hi_.data() + static_cast<std::size_t>(y) * row;
  for (int j = 0; j < width_; ++j) {
    rev_lo_[static_cast<std::size_t>(j)] = r_lo[width_ - 1 - j];
    rev_hi_[static_cast<std::size_t>(j)] = r_hi[width_ - 1 - j];
  }
  sgm::CostRowArgs a;
  a.left_low = census_l_lo_.data() + static_cast<std::size_t>(y) * row;
  a.left_high = census_l_hi_.data() + static_cast<std::size_t>(y) * row;
  a.right_rev_low = rev_lo_.data();
  a.right_rev_high = rev_hi_.data();
  a.pad_mask = pad_mask_.data();
  a.first = width_ - 1 + options_.min_disparity;
  a.width = width_;
  a.lanes = lanes_;
  a.cost = cost_.data();
  (reference_ ? sgm::reference_kernels() : sgm::simd_kernels()).cost_row(a);
  const auto neutral = static_cast<std::uint16_t>(options_.census_bits() / 2);
  const int last = std::min(width_, options_.min_disparity + range_);
  for (int x = 0; x < last; ++x) {
    std::uint16_t* c = cost_.data() + static_cast<std::size_t>(x) * lanes_;
    for (int k = std::max(0, x - options_.min_disparity + 1); k < range_; ++k) c[k] = neutral;
  }
}

// One pass: dir = +1 top-down (sums into volume_), -1 bottom-up (adds volume_, decides each
// row into `disparity`).
void SgmMatcher::pass(int dir, cv::Mat& disparity) {
  rows_.fill(kSgmMaskedCost);
  horizontal_.fill(kSgmMaskedCost);  // its guards may hold the other recursion's costs
  std::fill(row_min_.begin(), row_min_.end(), kSgmMaskedCost);
  const std::size_t slots = static_cast<std::size_t>(width_ + 2) * (lanes_ + kSgmGuard);
  const std::size_t mins = static_cast<std::size_t>(width_ + 2);
  const int num_vertical = options_.paths == 8 ? 3 : 1;
  const int dxs[3] = {num_vertical == 3 ? -1 : 0, 0, 1};
  const sgm::Kernels& k = reference_ ? sgm::reference_kernels() : sgm::simd_kernels();
  const auto aggregate_row = runs_8bit_paths() ? k.aggregate_row8 : k.aggregate_row;
  const std::size_t plane = static_cast<std::size_t>(width_) * lanes_;
  for (int i = 0; i < height_; ++i) {
    const int y = dir > 0 ? i : height_ - 1 - i;
    cost_row(y);
    sgm::AggregateRowArgs a;
    a.cost = cost_.data();
    a.add = dir > 0 ? nullptr : volume_.data() + static_cast<std::size_t>(y) * plane;
    a.sum = dir > 0 ? volume_.data() + static_cast<std::size_t>(y) * plane : total_.data();
    a.horizontal = horizontal_.data();
    a.num_vertical = num_vertical;
    const std::size_t cur = static_cast<std::size_t>(i & 1), prev = cur ^ 1;
    for (int r = 0; r < num_vertical; ++r) {
      const auto block = static_cast<std::size_t>(r) * 2;
      a.vertical[r] = {
          rows_.data() + (block + prev) * slots, row_min_.data() + (block + prev) * mins,
          rows_.data() + (block + cur) * slots, row_min_.data() + (block + cur) * mins, dxs[r]};
    }
    a.image = left_.ptr<std::uint8_t>(y);
    a.image_prev = left_.ptr<std::uint8_t>(i == 0 ? y : y - dir);
    a.p2_lut = p2_lut_.data() + 255;
    a.p2_scratch = p2_row_.data();
    a.pad_mask = pad_mask_.data();
    a.p1 = static_cast<std::uint16_t>(options_.p1);
    a.width = width_;
    a.lanes = lanes_;
    a.step = dir;
    aggregate_row(a);
    if (dir < 0) decide_row(y, disparity.ptr<float>(y));
  }
}

// The left-right check of pixel x with winning lane k: the right pixel xr = x - d has its least
// summed cost somewhere; the check passes iff one of the lanes k +- lr_max_diff on xr's diagonal
// (left pixel xr + min_disparity + k', lane k') reaches it (ties count as consistent). Pixels
// whose right pixel lies outside the image cannot be checked and keep their disparity.
bool SgmMatcher::left_right_consistent(int x, int k) const {
  const int xr = x - options_.min_disparity - k;
  if (xr < 0) return true;
  const std::uint16_t right_min =
      right_min_rev_[static_cast<std::size_t>(width_ - 1 - options_.min_disparity - xr)];
  const int lo = std::max(0, k - options_.lr_max_diff);
  const int hi = std::min(range_ - 1, k + options_.lr_max_diff);
  for (int kk = lo; kk <= hi; ++kk) {
    const int xl = xr + options_.min_disparity + kk;
    if (xl >= width_) break;
    if (total_[static_cast<std::size_t>(xl) * lanes_ + kk] <= right_min) return true;
  }
  return false;
}

// Row y, all paths summed in total_: winners, subpixel parabola, and the left-right check's
// verdict (applied by finish(), after the median).
void SgmMatcher::decide_row(int y, float* out) {
  sgm::DecideRowArgs a;
  a.sum = total_.data();
  a.width = width_;
  a.lanes = lanes_;
  a.best = best_.data();
  a.best_cost = best_cost_.data();
  // The right view's minima serve the left-right check only.
  a.right_min_rev = options_.lr_max_diff >= 0 ? right_min_rev_.data() : nullptr;
  (reference_ ? sgm::reference_kernels() : sgm::simd_kernels()).decide_row(a);
  std::uint8_t* rejected = rejected_.data() + static_cast<std::size_t>(y) * width_;
  for (int x = 0; x < width_; ++x) {
    out[x] = kNoDisparity;
    rejected[x] = 0;
    if (x < options_.min_disparity) continue;  // unreachable: nothing searched
    const int k = best_[static_cast<std::size_t>(x)];
    rejected[x] = options_.lr_max_diff >= 0 && !left_right_consistent(x, k) ? 1 : 0;
    float d = static_cast<float>(options_.min_disparity + k);
    if (options_.subpixel && k > 0 && k + 1 < range_) {
      const std::uint16_t* s = total_.data() + static_cast<std::size_t>(x) * lanes_;
      const int c0 = best_cost_[static_cast<std::size_t>(x)], cm = s[k - 1], cp = s[k + 1];
      const int curvature = cm + cp - 2 * c0;
      if (curvature > 0) d += static_cast<float>(cm - cp) / static_cast<float>(2 * curvature);
    }
    out[x] = d;
  }
}

// The 3x3 median of the winners (Hirschmueller 2008, section 4.1: it removes isolated
// outliers and keeps edges), then the left-right check's removals and the counts.
void SgmMatcher::finish(cv::Mat& disparity, MatchStats& stats) {
  if (options_.median) {
    cv::medianBlur(disparity, median_, 3);
    median_.copyTo(disparity);
  }
  for (int y = 0; y < height_; ++y) {
    float* d = disparity.ptr<float>(y);
    const std::uint8_t* rejected = rejected_.data() + static_cast<std::size_t>(y) * width_;
    for (int x = 0; x < width_; ++x) {
      if (x < options_.min_disparity) {
        d[x] = kNoDisparity;
        ++stats.unreachable;
      } else if (rejected[x] != 0 || !has_disparity(d[x])) {
        d[x] = kNoDisparity;
        ++stats.rejected_lr;
      } else {
        ++stats.valid;
      }
    }
  }
}

// Small regions of similar disparity, isolated from their surroundings, are mostly mismatches
// (Hirschmueller 2008, section 4.1): cv::filterSpeckles on 1/16 px fixed point removes them.
void SgmMatcher::remove_speckles(cv::Mat& disparity, MatchStats& stats) {
  speckle_fixed_.create(disparity.size(), CV_16SC1);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    auto* f = speckle_fixed_.ptr<std::int16_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      f[x] = has_disparity(d[x]) ? static_cast<std::int16_t>(std::lround(16.0F * d[x])) : -1;
    }
  }
  cv::filterSpeckles(speckle_fixed_, -1, options_.speckle_size, 16.0 * options_.speckle_max_diff,
                     speckle_buffer_);
  for (int y = 0; y < disparity.rows; ++y) {
    float* d = disparity.ptr<float>(y);
    const auto* f = speckle_fixed_.ptr<std::int16_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (f[x] < 0 && has_disparity(d[x])) {
        d[x] = kNoDisparity;
        --stats.valid;
        ++speckles_removed_;
      }
    }
  }
}

MatchStats SgmMatcher::match(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity) {
  if (left.empty() || right.empty()) throw InputError("semi-global matcher: empty image");
  if (left.size() != right.size()) {
    throw InputError("semi-global matcher: the left and right images differ in size");
  }
  left_ = grey8(left, gray_l_, "left");
  const cv::Mat right_gray = grey8(right, gray_r_, "right");
  prepare(left.cols, left.rows);
  p2_lut_.resize(511);  // P2 by intensity difference -255..255 (symmetric: the kernels index it
  for (int di = 0; di < 256; ++di) {  // by the signed difference)
    const int g = options_.p2_gradient;
    const int p2 = g == 0 ? options_.p2 : options_.p2 * g / (g + di);
    const auto value = static_cast<std::uint16_t>(std::max(options_.p1, p2));
    p2_lut_[static_cast<std::size_t>(255 + di)] = value;
    p2_lut_[static_cast<std::size_t>(255 - di)] = value;
  }
  census(left_, census_l_lo_, census_l_hi_);
  census(right_gray, census_r_lo_, census_r_hi_);
  disparity.create(left.size(), CV_32FC1);
  MatchStats stats;
  stats.pixels = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  pass(+1, disparity);
  pass(-1, disparity);
  finish(disparity, stats);
  speckles_removed_ = 0;
  if (options_.speckle_size > 0) remove_speckles(disparity, stats);
  return stats;
}

cv::Mat SgmMatcher::match(const cv::Mat& left, const cv::Mat& right) {
  cv::Mat d;
  match(left, right, d);
  return d;
}

}  // namespace kestrel::sensor
