// Block matching on a rectified pair: running column sums of per-pixel costs (one row in, one
// row out per image row), running box sums along the row, winner-take-all per pixel. Costs are
// uint16 with the disparities of one pixel contiguous and stored in REVERSED order (lane
// k <-> d = max_lane_d - k), so that the right-image pixels a lane row needs are contiguous and
// increasing: right index = left column + lane. Optimisation notes: docs/stereo.md.
#include "kestrel/sensor/block_matcher.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "block_matcher_kernels.hpp"
#include "grey_input.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::sensor {
namespace {

using kernels::kCandidate;
using kernels::kFieldCount;
using kernels::kFieldStride;
using kernels::kLowTexture;
using kernels::kMaskedCost;
using kernels::kNotUnique;
using kernels::kRingGuard;
using kernels::kRingSlots;
using kernels::kUnreachable;
using kernels::RowScan;
using kernels::RowState;

// The SIMD kernels need vectors of at least 8 uint16 lanes (128 bits).
constexpr int kMinVectorLanes = 8;

// Buffers of uint16 costs read and written a vector at a time start on a cache line: they are
// allocated kAlignSlack elements longer and used from align64(data()).
constexpr std::size_t kAlignSlack = 32;
inline std::uint16_t* align64(std::uint16_t* p) {
  const auto a = reinterpret_cast<std::uintptr_t>(p);
  return reinterpret_cast<std::uint16_t*>((a + 63) & ~std::uintptr_t{63});
}

/// box += add - sub over n uint16 lanes.
inline void slide_u16(std::uint16_t* box, const std::uint16_t* add, const std::uint16_t* sub,
                      int n) {
  for (int i = 0; i < n; ++i) {
    box[i] = static_cast<std::uint16_t>(box[i] + add[i] - sub[i]);
  }
}

/// colsum[k] += |ln - rn[k]| - |lo - ro[k]| for k < n: one SAD column slides down one row.
inline void slide_sad_column(std::uint16_t* colsum, std::uint8_t ln, const std::uint8_t* rn,
                             std::uint8_t lo, const std::uint8_t* ro, int n) {
  for (int i = 0; i < n; ++i) {
    const int a_new = std::abs(int{ln} - int{rn[i]});
    const int a_old = std::abs(int{lo} - int{ro[i]});
    colsum[i] = static_cast<std::uint16_t>(colsum[i] + a_new - a_old);
  }
}

inline int clampi(int v, int lo, int hi) { return std::min(std::max(v, lo), hi); }

}  // namespace

// ---------------------------------------------------------------------------------------------
// Options

std::string_view to_string(MatchingCost cost) {
  return cost == MatchingCost::kSad ? "sad" : "census";
}

std::string_view to_string(Prefilter prefilter) {
  return prefilter == Prefilter::kNone ? "none" : "xsobel";
}

void parse_option(std::string_view name, MatchingCost& cost) {
  if (name == "sad") {
    cost = MatchingCost::kSad;
  } else if (name == "census") {
    cost = MatchingCost::kCensus;
  } else {
    throw std::invalid_argument("must be sad or census, got '" + std::string(name) + "'");
  }
}

void parse_option(std::string_view name, Prefilter& prefilter) {
  if (name == "none") {
    prefilter = Prefilter::kNone;
  } else if (name == "xsobel") {
    prefilter = Prefilter::kXSobel;
  } else {
    throw std::invalid_argument("must be none or xsobel, got '" + std::string(name) + "'");
  }
}

int BlockMatcherOptions::max_pixel_cost() const {
  if (cost == MatchingCost::kCensus) return census_window * census_window - 1;
  return prefilter == Prefilter::kXSobel ? 2 * prefilter_cap : 255;
}

void BlockMatcherOptions::validate() const {
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("block matcher: " + what);
  };
  if (min_disparity < 0) fail("min_disparity must be >= 0, got " + std::to_string(min_disparity));
  if (max_disparity <= min_disparity) {
    fail("the disparity range is empty: max_disparity (" + std::to_string(max_disparity) +
         ") must exceed min_disparity (" + std::to_string(min_disparity) + ")");
  }
  if (max_disparity - min_disparity > 1024) fail("at most 1024 disparities are searched");
  if (block_size < 3 || block_size % 2 == 0) {
    fail("block_size must be odd and >= 3, got " + std::to_string(block_size));
  }
  if (prefilter_cap < 1 || prefilter_cap > 127) {
    fail("prefilter_cap must lie in [1, 127], got " + std::to_string(prefilter_cap));
  }
  if (census_window != 3 && census_window != 5 && census_window != 7) {
    fail("census_window must be 3, 5 or 7, got " + std::to_string(census_window));
  }
  if (static_cast<long>(block_size) * block_size * max_pixel_cost() > 65535) {
    fail("block_size " + std::to_string(block_size) + " is too large for " +
         std::string(to_string(cost)) + " with prefilter " + std::string(to_string(prefilter)) +
         ": block_size^2 * " + std::to_string(max_pixel_cost()) + " must stay below 65536");
  }
  if (uniqueness_ratio < 0 || uniqueness_ratio > 100) {
    fail("uniqueness_ratio must lie in [0, 100], got " + std::to_string(uniqueness_ratio));
  }
  if (!(texture_threshold >= 0.0)) fail("texture_threshold must be >= 0");
  if (!(min_depth_m >= 0.0) || !(max_depth_m > min_depth_m)) {
    fail("need 0 <= min_depth_m < max_depth_m");
  }
}

std::string BlockMatcherOptions::describe() const {
  std::ostringstream os;
  os << "disparity=[" << min_disparity << "," << max_disparity << ") block=" << block_size
     << " cost=" << to_string(cost);
  if (cost == MatchingCost::kSad) {
    os << " prefilter=" << to_string(prefilter);
    if (prefilter == Prefilter::kXSobel) os << "(cap " << prefilter_cap << ")";
  } else {
    os << " census_window=" << census_window;
  }
  os << " subpixel=" << (subpixel ? "on" : "off") << " lr_max_diff=" << lr_max_diff
     << " uniqueness=" << uniqueness_ratio << "% texture=" << texture_threshold << " depth=["
     << min_depth_m << "," << max_depth_m << "] m";
  return os.str();
}

std::string BlockMatcherOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

BlockMatcherOptions BlockMatcherOptions::load_yaml(const std::filesystem::path& path) {
  BlockMatcherOptions o;
  io::option_fields::read_fields(io::load_yaml_map(path, "block matcher"), path.string(),
                                 "block matcher", o);
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(path.string() + ": " + e.what());
  }
  return o;
}

std::string MatchStats::describe() const {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(1);
  const auto pct = [&](std::size_t n) {
    return pixels == 0 ? 0.0 : 100.0 * static_cast<double>(n) / static_cast<double>(pixels);
  };
  os << "fill " << pct(valid) << "% (rejected: texture " << pct(rejected_texture)
     << "%, uniqueness " << pct(rejected_uniqueness) << "%, left-right " << pct(rejected_lr)
     << "%, depth range " << pct(rejected_depth) << "%, unreachable " << pct(unreachable) << "%)";
  return os.str();
}

// ---------------------------------------------------------------------------------------------
// Matcher

BlockMatcher::BlockMatcher(BlockMatcherOptions options, std::optional<RectifiedStereo> rig)
    : options_(options), rig_(rig) {
  options_.validate();
  if (rig_) rig_->validate();
  const bool depth_range = options_.min_depth_m > 0.0 || std::isfinite(options_.max_depth_m);
  if (depth_range && !rig_) {
    throw std::invalid_argument(
        "block matcher: a depth range (min_depth_m/max_depth_m) needs a calibrated rig");
  }
  if (rig_) {
    const double bf = rig_->baseline_m * rig_->f;
    d_min_valid_ =
        std::isfinite(options_.max_depth_m) ? static_cast<float>(bf / options_.max_depth_m) : 0.0F;
    d_max_valid_ =
        options_.min_depth_m > 0.0 ? static_cast<float>(bf / options_.min_depth_m) : kNoDisparity;
  }
  radius_ = options_.block_size / 2;
  const int n = options_.max_disparity - options_.min_disparity;
  lanes_ = (n + 31) / 32 * 32;  // whole 256-bit vectors of uint8 per-pixel costs
  pad_left_ = lanes_ - 1 + options_.min_disparity + radius_;
  const int block = options_.block_size;
  texture_min_ =
      static_cast<std::uint32_t>(std::ceil(options_.texture_threshold * 2.0 * block * block));
  // The fast row tags each box cost with lane / 8 in its low bits (2 bits for 32 lanes, 3 for
  // 64): the tagged costs must stay below the 0xFFFF of a masked lane.
  if (lanes_ == 32 || lanes_ == 64) {
    const int bits = lanes_ == 32 ? 2 : 3;
    const long max_box = static_cast<long>(block) * block * options_.max_pixel_cost();
    fast_ = (max_box << bits) + (1L << bits) - 1 < 0xFFFF &&
            options_.lr_max_diff <= kernels::kFastMaxLrDiff;
  }
}

void BlockMatcher::select_simd_target() {
  // Asked every match: tests switch the dispatch's target between matches, and the fast row's
  // storage order depends on its vector width.
  const int vector_lanes = portable_ ? 0 : kernels::vector_lanes();
  if (vector_lanes == vector_lanes_) return;
  vector_lanes_ = vector_lanes;
  if (!fast_ || vector_lanes < kMinVectorLanes) return;
  // The fast row's tables: where each lane sits in a slot (guard lanes where they are), and
  // for each winner b the mask of the lanes b - 1 .. b + 1.
  const int guard = kernels::kRingGuard;
  lane_positions_.resize(static_cast<std::size_t>(lanes_ + 2 * guard));
  for (int k = -guard; k < lanes_ + guard; ++k) {
    lane_positions_[static_cast<std::size_t>(k + guard)] = static_cast<std::int16_t>(
        k >= 0 && k < lanes_ ? kernels::fast_lane_position(k, vector_lanes) : k);
  }
  const auto L = static_cast<std::size_t>(lanes_);
  near_masks_.assign(L * L + kAlignSlack, 0);
  std::uint16_t* masks = align64(near_masks_.data());
  for (int b = 0; b < lanes_; ++b) {
    for (int at = 0; at < lanes_; ++at) {
      if (std::abs(kernels::fast_lane_position(at, vector_lanes) - b) <= 1) {
        masks[static_cast<std::size_t>(b) * L + static_cast<std::size_t>(at)] = kMaskedCost;
      }
    }
  }
}

void BlockMatcher::prepare(int width, int height) {
  if (width == width_ && height == height_) return;
  width_ = width;
  height_ = height;
  const int r = radius_;
  const int block = 2 * r + 1;
  row_stride_l_ = width + 2 * r;
  row_stride_r_ = width + r + pad_left_;
  const auto cols = static_cast<std::size_t>(row_stride_l_);
  const auto lanes = static_cast<std::size_t>(lanes_);
  const bool census = options_.cost == MatchingCost::kCensus;
  left_.assign(census ? 0 : cols * static_cast<std::size_t>(height), 0);
  right_.assign(
      census ? 0 : static_cast<std::size_t>(row_stride_r_) * static_cast<std::size_t>(height), 0);
  census_l_.assign(census ? cols * static_cast<std::size_t>(height) : 0, 0);
  census_r_.assign(
      census ? static_cast<std::size_t>(row_stride_r_) * static_cast<std::size_t>(height) : 0, 0);
  cost_ring_.assign(census ? static_cast<std::size_t>(block) * cols * lanes : 0, 0);
  column_sums_.assign(cols * lanes + kAlignSlack, 0);
  texture_columns_.assign(cols, 0);
  volume_.assign(static_cast<std::size_t>(width) * lanes, 0);
  right_min_.assign(static_cast<std::size_t>(width) + lanes + 1, 0);  // + 1: 32-bit gathers
  row_disp_.assign(static_cast<std::size_t>(width), -1);
  row_state_.assign(static_cast<std::size_t>(width), 0);
  gradient_.assign(texture_min_ > 0 ? cols * static_cast<std::size_t>(height) : 0, 0);
  volume_ring_.assign(fast_ ? kRingSlots * kernels::fast_ring_slot(lanes) + kAlignSlack : 0,
                      kMaskedCost);
  row_fields_.assign(fast_ && width <= kFieldStride ? std::size_t{kFieldCount} * kFieldStride : 0,
                     0);
}

// The scalar reference of the census kernel: one pass per neighbour, in the signature's bit
// order (each shifts the signatures left and brings in its bit).
void kernels::census_signatures_reference(const std::uint8_t* const* rows, int cr, int count,
                                          std::uint64_t* out) {
  std::fill(out, out + std::max(count, 0), std::uint64_t{0});
  const std::uint8_t* centres = rows[cr];
  for (int dy = -cr; dy <= cr; ++dy) {
    const std::uint8_t* row = rows[dy + cr];
    for (int dx = -cr; dx <= cr; ++dx) {
      if (dx == 0 && dy == 0) continue;
      for (int i = 0; i < count; ++i) {
        out[i] = (out[i] << 1) | static_cast<std::uint64_t>(row[i + dx] < centres[i]);
      }
    }
  }
}

namespace {

/// |I(y, x+1) - I(y, x-1)| for padded column c (x = c - r, clamped to the image).
inline std::uint32_t gradient_at(const std::uint8_t* row, int c, int r, int w) {
  const int x = clampi(c - r, 0, w - 1);
  return static_cast<std::uint32_t>(
      std::abs(int{row[std::min(x + 1, w - 1)]} - int{row[std::max(x - 1, 0)]}));
}

/// The census signatures of row y of `img` into the padded row `out` (stride columns, pad of
/// them left of pixel 0, replicated borders), for a census window of radius cr: the columns
/// whose window lies inside the row by census_signatures (SIMD) or its reference, the others
/// one at a time with clamps.
void census_row(const cv::Mat& img, int y, int cr, std::uint64_t* out, int stride, int pad,
                bool simd) {
  const int w = img.cols, h = img.rows;
  const int lo = std::min(stride, pad + cr), hi = std::max(lo, std::min(stride, pad + w - cr));
  std::array<const std::uint8_t*, 7> rows{};  // census_window <= 7 (validate)
  for (int dy = -cr; dy <= cr; ++dy) {
    rows[static_cast<std::size_t>(dy + cr)] =
        img.ptr<std::uint8_t>(clampi(y + dy, 0, h - 1)) + (lo - pad);
  }
  if (simd) {
    kernels::census_signatures(rows.data(), cr, hi - lo, out + lo);
  } else {
    kernels::census_signatures_reference(rows.data(), cr, hi - lo, out + lo);
  }
  for (int c = 0; c < stride; ++c) {
    if (c == lo) c = hi;  // the interior is done
    if (c >= stride) break;
    const int x = clampi(c - pad, 0, w - 1);
    const int centre = img.ptr<std::uint8_t>(y)[x];
    std::uint64_t bits = 0;
    for (int dy = -cr; dy <= cr; ++dy) {
      const std::uint8_t* row = img.ptr<std::uint8_t>(clampi(y + dy, 0, h - 1));
      for (int dx = -cr; dx <= cr; ++dx) {
        if (dx == 0 && dy == 0) continue;
        bits = (bits << 1) | static_cast<std::uint64_t>(row[clampi(x + dx, 0, w - 1)] < centre);
      }
    }
    out[c] = bits;
  }
}

/// |I(x+1) - I(x-1)| of each row of `img` per padded column (x = c - rad, clamped), `cols`
/// columns a row.
void gradient_rows(const cv::Mat& img, int rad, int cols, std::uint8_t* gradient) {
  const int w = img.cols;
  for (int y = 0; y < img.rows; ++y) {
    const std::uint8_t* row = img.ptr<std::uint8_t>(y);
    std::uint8_t* g = gradient + static_cast<std::size_t>(y) * static_cast<std::size_t>(cols);
    // Columns of pixels 1..w-2 need no clamps (a loop that vectorises); the rest do.
    const int lo = std::min(rad + 1, cols), hi = std::max(lo, rad + w - 1);
    for (int c = 0; c < lo; ++c) g[c] = static_cast<std::uint8_t>(gradient_at(row, c, rad, w));
    for (int c = lo; c < hi; ++c) {
      g[c] = static_cast<std::uint8_t>(std::abs(int{row[c - rad + 1]} - int{row[c - rad - 1]}));
    }
    for (int c = hi; c < cols; ++c) g[c] = static_cast<std::uint8_t>(gradient_at(row, c, rad, w));
  }
}

}  // namespace

void BlockMatcher::preprocess(const cv::Mat& left, const cv::Mat& right) {
  const cv::Mat l = grey8(left, gray_l_, "left");
  const cv::Mat r = grey8(right, gray_r_, "right");
  const int w = width_, h = height_, rad = radius_;
  if (options_.cost == MatchingCost::kSad) {
    // Prefiltered value per image pixel, then replicated into the padded rows.
    const int cap = options_.prefilter_cap;
    const bool sobel = options_.prefilter == Prefilter::kXSobel;
    const auto filter_row = [&](const cv::Mat& img, int y, std::uint8_t* out, int stride, int pad) {
      const std::uint8_t* r0 = img.ptr<std::uint8_t>(std::max(y - 1, 0));
      const std::uint8_t* r1 = img.ptr<std::uint8_t>(y);
      const std::uint8_t* r2 = img.ptr<std::uint8_t>(std::min(y + 1, h - 1));
      std::uint8_t* o = out + pad;
      if (!sobel) {
        std::memcpy(o, r1, static_cast<std::size_t>(w));
      } else {
        // Horizontal Sobel, clamped to +-cap and shifted to [0, 2 cap] (as OpenCV StereoBM);
        // the interior loop has no index clamps so that it vectorises.
        const auto at = [&](int x) {
          const int xm = std::max(x - 1, 0), xp = std::min(x + 1, w - 1);
          const int g = (r0[xp] - r0[xm]) + 2 * (r1[xp] - r1[xm]) + (r2[xp] - r2[xm]);
          return static_cast<std::uint8_t>(clampi(g, -cap, cap) + cap);
        };
        o[0] = at(0);
        // In int16 (|g| <= 1020), so that it vectorises 16 pixels to a register.
        const auto cap16 = static_cast<std::int16_t>(cap);
        for (int x = 1; x < w - 1; ++x) {
          const auto g = static_cast<std::int16_t>(
              (r0[x + 1] - r0[x - 1]) + 2 * (r1[x + 1] - r1[x - 1]) + (r2[x + 1] - r2[x - 1]));
          o[x] = static_cast<std::uint8_t>(
              std::min<std::int16_t>(std::max<std::int16_t>(g, static_cast<std::int16_t>(-cap16)),
                                     cap16) +
              cap16);
        }
        if (w > 1) o[w - 1] = at(w - 1);
      }
      std::memset(out, out[pad], static_cast<std::size_t>(pad));
      std::memset(out + pad + w, out[pad + w - 1], static_cast<std::size_t>(stride - pad - w));
    };
    for (int y = 0; y < h; ++y) {
      filter_row(
          l, y,
          left_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_l_),
          row_stride_l_, rad);
      filter_row(
          r, y,
          right_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_r_),
          row_stride_r_, pad_left_);
    }
  } else {
    const int cr = options_.census_window / 2;
    for (int y = 0; y < h; ++y) {
      census_row(
          l, y, cr,
          census_l_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_l_),
          row_stride_l_, rad, simd());
      census_row(
          r, y, cr,
          census_r_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_r_),
          row_stride_r_, pad_left_, simd());
    }
  }
  // Texture: |I(x+1) - I(x-1)| of the raw left image per padded column (x = c - r, clamped).
  if (texture_min_ > 0) gradient_rows(l, rad, row_stride_l_, gradient_.data());
}

bool BlockMatcher::simd() const { return vector_lanes_ >= kMinVectorLanes; }

bool BlockMatcher::fast_row() const { return fast_ && simd() && width_ <= kFieldStride; }

int BlockMatcher::column_scale() const { return fast_row() ? (lanes_ == 32 ? 4 : 8) : 1; }

int BlockMatcher::storage_order() const { return fast_row() ? vector_lanes_ : 0; }

void BlockMatcher::init_column_sums() {
  const int r = radius_, h = height_;
  const int cols = row_stride_l_, lanes = lanes_;
  const int block = 2 * r + 1;
  // The fast row's column sums are scaled and permuted in runs of 8 lanes (storage_order).
  const int scale = column_scale();
  // A copy, not this->: the stores through uint16 pointers could alias the matcher's fields.
  const auto run_at = [order = storage_order()](int lane) {
    return static_cast<std::size_t>(kernels::fast_lane_position(lane, order));
  };
  std::fill(column_sums_.begin(), column_sums_.end(), std::uint16_t{0});
  std::fill(texture_columns_.begin(), texture_columns_.end(), 0U);
  for (int k = -r; k <= r; ++k) {
    const int y = clampi(k, 0, h - 1);
    if (texture_min_ > 0) {
      const std::uint8_t* g =
          gradient_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(cols);
      for (int c = 0; c < cols; ++c) texture_columns_[static_cast<std::size_t>(c)] += g[c];
    }
    if (options_.cost == MatchingCost::kSad) {
      const std::uint8_t* lrow =
          left_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(cols);
      const std::uint8_t* rrow =
          right_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_r_);
      if (fast_row()) {
        kernels::add_sad_row_fast(align64(column_sums_.data()), lrow, rrow, cols, lanes,
                                  std::countr_zero(static_cast<unsigned>(scale)));
        continue;
      }
      for (int c = 0; c < cols; ++c) {
        std::uint16_t* cs = align64(column_sums_.data()) +
                            static_cast<std::size_t>(c) * static_cast<std::size_t>(lanes);
        for (int i0 = 0; i0 < lanes; i0 += 8) {  // the storage order keeps runs of 8 lanes
          std::uint16_t* sum = cs + run_at(i0);
          for (int i = 0; i < 8; ++i) {
            sum[i] = static_cast<std::uint16_t>(
                sum[i] + scale * std::abs(int{lrow[c]} - int{rrow[c + i0 + i]}));
          }
        }
      }
    } else {
      const std::uint64_t* lrow =
          census_l_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(cols);
      const std::uint64_t* rrow =
          census_r_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_r_);
      const int slot = ((k % block) + block) % block;
      std::uint8_t* ring = cost_ring_.data() + static_cast<std::size_t>(slot) *
                                                   static_cast<std::size_t>(cols) *
                                                   static_cast<std::size_t>(lanes);
      for (int c = 0; c < cols; ++c) {
        std::uint16_t* cs = align64(column_sums_.data()) +
                            static_cast<std::size_t>(c) * static_cast<std::size_t>(lanes);
        std::uint8_t* rc = ring + static_cast<std::size_t>(c) * static_cast<std::size_t>(lanes);
        for (int i0 = 0; i0 < lanes; i0 += 8) {
          std::uint16_t* sum = cs + run_at(i0);
          for (int i = 0; i < 8; ++i) {
            const auto pc = static_cast<std::uint8_t>(std::popcount(lrow[c] ^ rrow[c + i0 + i]));
            rc[i0 + i] = pc;
            sum[i] = static_cast<std::uint16_t>(sum[i] + scale * pc);
          }
        }
      }
    }
  }
}

void BlockMatcher::advance_column_sums(int y) {
  // The window of row y covers rows y-r..y+r: row y+r comes in, row y-r-1 goes out.
  const int r = radius_, h = height_;
  const int cols = row_stride_l_, lanes = lanes_;
  const int block = 2 * r + 1;
  const int scale = column_scale();
  const int k_new = y + r;
  const int y_new = std::min(k_new, h - 1);
  const int y_old = std::max(y - r - 1, 0);
  if (texture_min_ > 0) {
    const std::uint8_t* g_new =
        gradient_.data() + static_cast<std::size_t>(y_new) * static_cast<std::size_t>(cols);
    const std::uint8_t* g_old =
        gradient_.data() + static_cast<std::size_t>(y_old) * static_cast<std::size_t>(cols);
    std::uint32_t* tc = texture_columns_.data();
    for (int c = 0; c < cols; ++c) tc[c] += static_cast<std::uint32_t>(g_new[c]) - g_old[c];
  }
  const auto lane_stride = static_cast<std::size_t>(lanes);
  // SAD columns are slid by the row scan itself, just before it uses them.
  if (options_.cost == MatchingCost::kCensus) {
    const std::uint64_t* lrow =
        census_l_.data() + static_cast<std::size_t>(y_new) * static_cast<std::size_t>(cols);
    const std::uint64_t* rrow = census_r_.data() + static_cast<std::size_t>(y_new) *
                                                       static_cast<std::size_t>(row_stride_r_);
    const int slot = k_new % block;  // the slot of row y-r-1 (same residue)
    std::uint8_t* ring = cost_ring_.data() + static_cast<std::size_t>(slot) *
                                                 static_cast<std::size_t>(cols) * lane_stride;
    kernels::census_slide_row(align64(column_sums_.data()), ring, lrow, rrow, cols, lanes, scale,
                              storage_order());
  }
}

namespace {

void scan_row_generic(const RowScan& s) {
  const auto L = static_cast<std::size_t>(s.lanes);
  const int block = 2 * s.radius + 1;
  const int cols = s.width + 2 * s.radius;
  if (s.left_new != nullptr) {
    for (int c = 0; c < cols; ++c) {
      slide_sad_column(s.column_sums + static_cast<std::size_t>(c) * L, s.left_new[c],
                       s.right_new + c, s.left_old[c], s.right_old + c, s.lanes);
    }
  }
  std::vector<std::uint16_t>& box = [&]() -> std::vector<std::uint16_t>& {
    thread_local std::vector<std::uint16_t> b;
    b.assign(L, 0);
    return b;
  }();
  std::uint32_t tex = 0;
  for (int c = 0; c < block; ++c) {
    const std::uint16_t* col = s.column_sums + static_cast<std::size_t>(c) * L;
    for (std::size_t i = 0; i < L; ++i) box[i] = static_cast<std::uint16_t>(box[i] + col[i]);
    tex += s.texture_columns[c];
  }
  std::fill(s.right_min, s.right_min + s.width + s.lanes, kMaskedCost);
  for (int x = 0; x < s.width; ++x) {
    if (x > 0) {
      slide_u16(box.data(), s.column_sums + static_cast<std::size_t>(x + 2 * s.radius) * L,
                s.column_sums + static_cast<std::size_t>(x - 1) * L, s.lanes);
      tex += s.texture_columns[x + 2 * s.radius] - s.texture_columns[x - 1];
    }
    std::uint16_t* vol = s.volume + static_cast<std::size_t>(x) * L;
    std::memcpy(vol, box.data(), L * sizeof(std::uint16_t));
    const int first = s.first_lane(x);
    s.winner_lane[x] = -1;
    if (first >= s.lanes) {
      s.state[x] = kUnreachable;
      continue;
    }
    int best = first;
    for (int k = first; k < s.lanes; ++k) {
      if (vol[k] < vol[best]) best = k;
      // Lane k at x is the candidate d = d_top - k for right pixel x - d = x - d_top + k.
      s.right_min[x + k] = std::min(s.right_min[x + k], vol[k]);
    }
    const int c0 = vol[best];
    if (tex < s.texture_min) {
      s.state[x] = kLowTexture;
      continue;
    }
    if (s.uniqueness > 0) {
      int second = kMaskedCost;
      for (int k = first; k < s.lanes; ++k) {
        if (k < best - 1 || k > best + 1) second = std::min(second, int{vol[k]});
      }
      if (second * 100 <= c0 * (100 + s.uniqueness)) {
        s.state[x] = kNotUnique;
        continue;
      }
    }
    s.state[x] = kCandidate;
    s.winner_lane[x] = best;
  }
}

void finish_row(const RowScan& s, int lr, bool subpixel, bool census, float d_min, float d_max,
                float* out, MatchStats& stats);

}  // namespace

void BlockMatcher::match_row(int y, float* out, MatchStats& stats) {
  const int w = width_, lanes = lanes_;
  const int num = options_.max_disparity - options_.min_disparity;
  const int d_top = options_.min_disparity + lanes - 1;  // disparity of lane 0
  RowScan scan{align64(column_sums_.data()),
               texture_columns_.data(),
               w,
               radius_,
               lanes,
               num,
               d_top,
               options_.uniqueness_ratio,
               texture_min_,
               volume_.data(),
               right_min_.data(),
               row_disp_.data(),
               row_state_.data()};
  if (options_.cost == MatchingCost::kSad && y > 0) {
    const int r = radius_, h = height_;
    const int y_new = std::min(y + r, h - 1), y_old = std::max(y - r - 1, 0);
    scan.left_new =
        left_.data() + static_cast<std::size_t>(y_new) * static_cast<std::size_t>(row_stride_l_);
    scan.left_old =
        left_.data() + static_cast<std::size_t>(y_old) * static_cast<std::size_t>(row_stride_l_);
    scan.right_new =
        right_.data() + static_cast<std::size_t>(y_new) * static_cast<std::size_t>(row_stride_r_);
    scan.right_old =
        right_.data() + static_cast<std::size_t>(y_old) * static_cast<std::size_t>(row_stride_r_);
  }
  if (fast_row()) {
    const kernels::FastRow f{align64(volume_ring_.data()),
                             row_fields_.data(),
                             align64(near_masks_.data()),
                             lane_positions_.data() + kRingGuard,
                             options_.lr_max_diff,
                             options_.subpixel,
                             options_.cost == MatchingCost::kCensus,
                             d_min_valid_,
                             d_max_valid_,
                             texture_min_ > 0,
                             options_.max_pixel_cost() < 128};
    kernels::match_row_fast(scan, f, out, stats);
    return;
  }
  if (simd() && lanes <= kernels::kMaxSimdLanes) {
    kernels::scan_row(scan);
  } else {
    scan_row_generic(scan);
  }
  finish_row(scan, options_.lr_max_diff, options_.subpixel, options_.cost == MatchingCost::kCensus,
             d_min_valid_, d_max_valid_, out, stats);
}

namespace {

/// The row's disparities after the row scan: the left-right check, the subpixel fit and the depth
/// range for the candidates, the counts for all.
void finish_row(const RowScan& s, int lr, bool subpixel, bool census, float d_min, float d_max,
                float* out, MatchStats& stats) {
  const int w = s.width, lanes = s.lanes, num = s.num, d_top = s.d_top;
  const auto L = static_cast<std::size_t>(lanes);
  for (int x = 0; x < w; ++x) {
    out[x] = kNoDisparity;
    switch (s.state[static_cast<std::size_t>(x)]) {
      case kUnreachable:
        ++stats.unreachable;
        continue;
      case kLowTexture:
        ++stats.rejected_texture;
        continue;
      case kNotUnique:
        ++stats.rejected_uniqueness;
        continue;
      default:
        break;
    }
    const int best = s.winner_lane[static_cast<std::size_t>(x)];
    const int d = d_top - best;
    const std::uint16_t* vol = s.volume + static_cast<std::size_t>(x) * L;
    const int c0 = vol[best];
    if (lr >= 0) {
      // Left-right check without a second pass: the right pixel x - d has its best cost
      // right_min; the check passes iff a candidate along its diagonal within lr px of d
      // (pixel x + j, disparity d + j) reaches that cost (ties count as consistent).
      const int right_best = s.right_min[static_cast<std::size_t>(x - d + d_top)];
      int diag = c0;
      for (int j = -lr; j <= lr && diag > right_best; ++j) {
        const int xj = x + j, kj = best - j;
        if (j == 0 || xj < 0 || xj >= w || kj < 0 || kj >= lanes) continue;
        if (kj < std::max(lanes - num, d_top - xj)) continue;  // out of range there
        diag = std::min(
            diag, int{s.volume[static_cast<std::size_t>(xj) * L + static_cast<std::size_t>(kj)]});
      }
      if (diag > right_best) {
        ++stats.rejected_lr;
        continue;
      }
    }
    float delta = 0.0F;
    const int first = std::max(lanes - num, d_top - x);
    // A zero cost is an exact match: no fit (an asymmetric cost curve would bias it).
    if (subpixel && c0 > 0 && best + 1 < lanes && best - 1 >= first) {
      const int cm = vol[best + 1], cp = vol[best - 1];  // costs at d - 1 and d + 1
      if (census) {
        const int denom = cm + cp - 2 * c0;
        if (denom > 0) delta = static_cast<float>(cm - cp) / static_cast<float>(2 * denom);
      } else {
        // Equiangular (V-shaped) fit, the right model for an L1 cost (Shimizu & Okutomi 2001).
        const int denom = std::max(cm, cp) - c0;
        if (denom > 0) delta = static_cast<float>(cm - cp) / static_cast<float>(2 * denom);
      }
    }
    const float ds = static_cast<float>(d) + delta;
    if (ds < d_min || ds > d_max) {
      ++stats.rejected_depth;
      continue;
    }
    out[x] = ds;
    ++stats.valid;
  }
}

}  // namespace

MatchStats BlockMatcher::match(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity) {
  if (left.empty() || right.empty()) {
    throw InputError(std::string("stereo: the ") + (left.empty() ? "left" : "right") +
                     " image is empty");
  }
  if (left.size() != right.size()) {
    throw InputError("stereo: the left image is " + std::to_string(left.cols) + "x" +
                     std::to_string(left.rows) + " but the right one is " +
                     std::to_string(right.cols) + "x" + std::to_string(right.rows));
  }
  if (rig_ && (rig_->width != left.cols || rig_->height != left.rows)) {
    throw InputError("stereo: the images are " + std::to_string(left.cols) + "x" +
                     std::to_string(left.rows) + " but the calibration is for " +
                     std::to_string(rig_->width) + "x" + std::to_string(rig_->height));
  }
  prepare(left.cols, left.rows);
  select_simd_target();
  preprocess(left, right);
  disparity.create(height_, width_, CV_32F);
  MatchStats stats;
  stats.pixels = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  init_column_sums();
  for (int y = 0; y < height_; ++y) {
    if (y > 0) advance_column_sums(y);
    match_row(y, disparity.ptr<float>(y), stats);
  }
  return stats;
}

cv::Mat BlockMatcher::match(const cv::Mat& left, const cv::Mat& right) {
  cv::Mat disparity;
  match(left, right, disparity);
  return disparity;
}

void disparity_to_depth(const cv::Mat& disparity_px, const RectifiedStereo& rig, cv::Mat& depth_m) {
  CV_Assert(disparity_px.type() == CV_32F);
  depth_m.create(disparity_px.size(), CV_32F);
  const auto bf = static_cast<float>(rig.baseline_m * rig.f);
  for (int y = 0; y < disparity_px.rows; ++y) {
    const float* d = disparity_px.ptr<float>(y);
    float* z = depth_m.ptr<float>(y);
    for (int x = 0; x < disparity_px.cols; ++x) {
      z[x] = (has_disparity(d[x]) && d[x] > 0.0F) ? bf / d[x] : 0.0F;  // Z = B f / d, eq. 2.9
    }
  }
}

}  // namespace kestrel::sensor
