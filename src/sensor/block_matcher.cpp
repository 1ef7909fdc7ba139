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

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

// The fast row's per-pixel helpers must be inlined into their loops (GCC otherwise calls the
// larger ones, with every field of their state reloaded through the reference).
#if defined(__GNUC__)
#define KESTREL_INLINE __attribute__((always_inline))
#else
#define KESTREL_INLINE
#endif

namespace kestrel::sensor {
namespace {

constexpr std::uint16_t kMaskedCost = 0xFFFF;

// Buffers of uint16 costs read and written 32 bytes at a time start on a cache line: they are
// allocated kAlignSlack elements longer and used from align64(data()).
constexpr std::size_t kAlignSlack = 32;
inline std::uint16_t* align64(std::uint16_t* p) {
  const auto a = reinterpret_cast<std::uintptr_t>(p);
  return reinterpret_cast<std::uint16_t*>((a + 63) & ~std::uintptr_t{63});
}
// The fast row checks pixel x - kLag while it scans pixel x; its ring of box costs holds the
// last kRingSlots pixels (> kLag + kFastMaxLrDiff), each slot with kRingGuard masked lanes on
// either side, so that the left-right diagonal (|j| <= lr_max_diff <= kFastMaxLrDiff) and the
// fit's neighbours never leave the slots.
constexpr int kLag = 16;
constexpr int kFastMaxLrDiff = 8;
constexpr int kRingSlots = 32;
constexpr int kRingGuard = 16;  // 32 bytes: the slots' lanes stay 32-byte aligned
static_assert(kLag > kFastMaxLrDiff && kRingSlots > kLag + kFastMaxLrDiff &&
              kRingGuard >= kFastMaxLrDiff);

/// The fast row's storage order of the lanes in its column sums, ring and window (a swap of
/// bits 3 and 4, its own inverse): in each group of 32 lanes, register 2g holds lanes 0..7
/// and 16..23, register 2g + 1 lanes 8..15 and 24..31, the order in which punpck{l,h}bw
/// leave 32 byte lanes. Each half register is still 8 consecutive lanes, which is all the
/// tagged winner search needs.
constexpr int lane_at_position(int at) { return (at & ~0x18) | ((at & 8) << 1) | ((at & 16) >> 1); }

/// What scan_row_fast leaves per pixel for finish_row_fast: one uint16 field array each, all
/// at constant offsets from one base (kFieldStride apart), so that the scan addresses every
/// field from one register. Costs are stored TAGGED (see scan_row_fast) and decoded eight
/// pixels at a time by finish_row_fast.
enum FastField : int {
  kFieldCost,      // the winner's cost
  kFieldMinus,     // the cost at d - 1 (lane best + 1)
  kFieldPlus,      // the cost at d + 1 (lane best - 1)
  kFieldDiag,      // the least cost on the right pixel's diagonal within lr_max_diff
  kFieldSecond,    // the least cost further than 1 lane from the winner (0xFFFF: none)
  kFieldBest,      // the winner's lane (not tagged)
  kFieldCount
};
constexpr int kFieldStride = 8192;  // the fast row handles widths up to this

/// box += add - sub over n uint16 lanes.
inline void slide_u16(std::uint16_t* box, const std::uint16_t* add, const std::uint16_t* sub,
                      int n) {
#if defined(__AVX2__)
  for (int i = 0; i < n; i += 16) {
    auto* b = reinterpret_cast<__m256i*>(box + i);
    __m256i s = _mm256_loadu_si256(b);
    s = _mm256_add_epi16(s, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(add + i)));
    s = _mm256_sub_epi16(s, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(sub + i)));
    _mm256_storeu_si256(b, s);
  }
#else
  for (int i = 0; i < n; ++i) {
    box[i] = static_cast<std::uint16_t>(box[i] + add[i] - sub[i]);
  }
#endif
}

/// colsum[k] += |ln - rn[k]| - |lo - ro[k]| for k < n: one SAD column slides down one row.
inline void slide_sad_column(std::uint16_t* colsum, std::uint8_t ln, const std::uint8_t* rn,
                             std::uint8_t lo, const std::uint8_t* ro, int n) {
#if defined(__AVX2__)
  const __m256i vln = _mm256_set1_epi8(static_cast<char>(ln));
  const __m256i vlo = _mm256_set1_epi8(static_cast<char>(lo));
  for (int i = 0; i < n; i += 32) {
    const __m256i r_new = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(rn + i));
    const __m256i r_old = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(ro + i));
    const __m256i a_new =
        _mm256_or_si256(_mm256_subs_epu8(vln, r_new), _mm256_subs_epu8(r_new, vln));
    const __m256i a_old =
        _mm256_or_si256(_mm256_subs_epu8(vlo, r_old), _mm256_subs_epu8(r_old, vlo));
    auto* s0p = reinterpret_cast<__m256i*>(colsum + i);
    auto* s1p = reinterpret_cast<__m256i*>(colsum + i + 16);
    __m256i s0 = _mm256_loadu_si256(s0p);
    __m256i s1 = _mm256_loadu_si256(s1p);
    s0 = _mm256_add_epi16(s0, _mm256_cvtepu8_epi16(_mm256_castsi256_si128(a_new)));
    s0 = _mm256_sub_epi16(s0, _mm256_cvtepu8_epi16(_mm256_castsi256_si128(a_old)));
    s1 = _mm256_add_epi16(s1, _mm256_cvtepu8_epi16(_mm256_extracti128_si256(a_new, 1)));
    s1 = _mm256_sub_epi16(s1, _mm256_cvtepu8_epi16(_mm256_extracti128_si256(a_old, 1)));
    _mm256_storeu_si256(s0p, s0);
    _mm256_storeu_si256(s1p, s1);
  }
#else
  for (int i = 0; i < n; ++i) {
    const int a_new = std::abs(int{ln} - int{rn[i]});
    const int a_old = std::abs(int{lo} - int{ro[i]});
    colsum[i] = static_cast<std::uint16_t>(colsum[i] + a_new - a_old);
  }
#endif
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
     << " uniqueness=" << uniqueness_ratio << "% texture=" << texture_threshold
     << " depth=[" << min_depth_m << "," << max_depth_m << "] m";
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
     << "%, depth range " << pct(rejected_depth) << "%, unreachable " << pct(unreachable)
     << "%)";
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
    d_min_valid_ = std::isfinite(options_.max_depth_m)
                       ? static_cast<float>(bf / options_.max_depth_m) : 0.0F;
    d_max_valid_ = options_.min_depth_m > 0.0 ? static_cast<float>(bf / options_.min_depth_m)
                                              : kNoDisparity;
  }
  radius_ = options_.block_size / 2;
  const int n = options_.max_disparity - options_.min_disparity;
  lanes_ = (n + 31) / 32 * 32;  // whole AVX2 registers of uint8 per-pixel costs
  pad_left_ = lanes_ - 1 + options_.min_disparity + radius_;
  const int block = options_.block_size;
  texture_min_ = static_cast<std::uint32_t>(std::ceil(options_.texture_threshold * 2.0 * block * block));
#if defined(__AVX2__)
  // The fast row tags each box cost with lane / 8 in its low bits (2 bits for 32 lanes, 3 for
  // 64): the tagged costs must stay below the 0xFFFF of a masked lane.
  if (lanes_ == 32 || lanes_ == 64) {
    const int bits = lanes_ == 32 ? 2 : 3;
    const long max_box = static_cast<long>(block) * block * options_.max_pixel_cost();
    fast_ = (max_box << bits) + (1L << bits) - 1 < 0xFFFF && options_.lr_max_diff <= kFastMaxLrDiff;
  }
#endif
  if (fast_) {
    // The fast row's tables: where each lane sits in a slot (guard lanes where they are), and
    // for each winner b the mask of the lanes b - 1 .. b + 1.
    lane_positions_.resize(static_cast<std::size_t>(lanes_ + 2 * kRingGuard));
    for (int k = -kRingGuard; k < lanes_ + kRingGuard; ++k) {
      lane_positions_[static_cast<std::size_t>(k + kRingGuard)] =
          static_cast<std::int16_t>(k >= 0 && k < lanes_ ? lane_at_position(k) : k);
    }
    const auto L = static_cast<std::size_t>(lanes_);
    near_masks_.assign(L * L + kAlignSlack, 0);
    std::uint16_t* masks = align64(near_masks_.data());
    for (int b = 0; b < lanes_; ++b) {
      for (int at = 0; at < lanes_; ++at) {
        if (std::abs(lane_at_position(at) - b) <= 1) masks[static_cast<std::size_t>(b) * L + static_cast<std::size_t>(at)] = kMaskedCost;
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
  right_.assign(census ? 0 : static_cast<std::size_t>(row_stride_r_) * static_cast<std::size_t>(height), 0);
  census_l_.assign(census ? cols * static_cast<std::size_t>(height) : 0, 0);
  census_r_.assign(census ? static_cast<std::size_t>(row_stride_r_) * static_cast<std::size_t>(height) : 0, 0);
  cost_ring_.assign(census ? static_cast<std::size_t>(block) * cols * lanes : 0, 0);
  column_sums_.assign(cols * lanes + kAlignSlack, 0);
  texture_columns_.assign(cols, 0);
  volume_.assign(static_cast<std::size_t>(width) * lanes, 0);
  right_min_.assign(static_cast<std::size_t>(width) + lanes + 1, 0);  // + 1: 32-bit gathers
  row_disp_.assign(static_cast<std::size_t>(width), -1);
  row_state_.assign(static_cast<std::size_t>(width), 0);
  gradient_.assign(texture_min_ > 0 ? cols * static_cast<std::size_t>(height) : 0, 0);
  volume_ring_.assign(fast_ ? kRingSlots * (lanes + 2 * kRingGuard) + kAlignSlack : 0, kMaskedCost);
  row_fields_.assign(fast_ && width <= kFieldStride ? std::size_t{kFieldCount} * kFieldStride : 0, 0);
}

namespace {

cv::Mat to_gray8(const cv::Mat& image, cv::Mat& buffer, const char* which) {
  if (image.empty()) throw InputError(std::string("stereo: the ") + which + " image is empty");
  if (image.type() == CV_8UC1) return image;
  if (image.type() == CV_8UC3) {
    cv::cvtColor(image, buffer, cv::COLOR_BGR2GRAY);
    return buffer;
  }
  if (image.type() == CV_32FC1) {
    image.convertTo(buffer, CV_8U);  // saturating, rounded
    return buffer;
  }
  throw InputError(std::string("stereo: the ") + which +
                   " image must be 8-bit grey, 8-bit BGR or float grey, got OpenCV type " +
                   std::to_string(image.type()));
}

}  // namespace

namespace {

/// |I(y, x+1) - I(y, x-1)| for padded column c (x = c - r, clamped to the image).
inline std::uint32_t gradient_at(const std::uint8_t* row, int c, int r, int w) {
  const int x = clampi(c - r, 0, w - 1);
  return static_cast<std::uint32_t>(
      std::abs(int{row[std::min(x + 1, w - 1)]} - int{row[std::max(x - 1, 0)]}));
}

}  // namespace

void BlockMatcher::preprocess(const cv::Mat& left, const cv::Mat& right) {
  const cv::Mat l = to_gray8(left, gray_l_, "left");
  const cv::Mat r = to_gray8(right, gray_r_, "right");
  const int w = width_, h = height_, rad = radius_;
  const auto pixel = [](const cv::Mat& img, int y, int x) {
    return img.ptr<std::uint8_t>(y)[x];
  };
  if (options_.cost == MatchingCost::kSad) {
    // Prefiltered value per image pixel, then replicated into the padded rows.
    const int cap = options_.prefilter_cap;
    const bool sobel = options_.prefilter == Prefilter::kXSobel;
    const auto filter_row = [&](const cv::Mat& img, int y, std::uint8_t* out, int stride,
                                int pad) {
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
          const auto g = static_cast<std::int16_t>((r0[x + 1] - r0[x - 1]) + 2 * (r1[x + 1] - r1[x - 1]) +
                                                   (r2[x + 1] - r2[x - 1]));
          o[x] = static_cast<std::uint8_t>(std::min<std::int16_t>(std::max<std::int16_t>(g, static_cast<std::int16_t>(-cap16)), cap16) + cap16);
        }
        if (w > 1) o[w - 1] = at(w - 1);
      }
      std::memset(out, out[pad], static_cast<std::size_t>(pad));
      std::memset(out + pad + w, out[pad + w - 1], static_cast<std::size_t>(stride - pad - w));
    };
    for (int y = 0; y < h; ++y) {
      filter_row(l, y, left_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_l_), row_stride_l_, rad);
      filter_row(r, y, right_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_r_), row_stride_r_, pad_left_);
    }
  } else {
    const int cr = options_.census_window / 2;
    const auto census_row = [&](const cv::Mat& img, int y, std::uint64_t* out, int stride,
                                int pad) {
      // Columns whose window lies inside the row: one pass per neighbour, in the signature's
      // bit order, without clamps (a loop that vectorises); the others one at a time.
      const int lo = std::min(stride, pad + cr), hi = std::max(lo, std::min(stride, pad + w - cr));
      std::fill(out + lo, out + hi, std::uint64_t{0});
      const std::uint8_t* centres = img.ptr<std::uint8_t>(y) + (lo - pad);
      for (int dy = -cr; dy <= cr; ++dy) {
        const std::uint8_t* row = img.ptr<std::uint8_t>(clampi(y + dy, 0, h - 1)) + (lo - pad);
        for (int dx = -cr; dx <= cr; ++dx) {
          if (dx == 0 && dy == 0) continue;
          for (int i = 0; i < hi - lo; ++i) {
            out[lo + i] = (out[lo + i] << 1) | static_cast<std::uint64_t>(row[i + dx] < centres[i]);
          }
        }
      }
      for (int c = 0; c < stride; ++c) {
        if (c == lo) c = hi;  // the interior is done
        if (c >= stride) break;
        const int x = clampi(c - pad, 0, w - 1);
        const int centre = pixel(img, y, x);
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
    };
    for (int y = 0; y < h; ++y) {
      census_row(l, y, census_l_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_l_), row_stride_l_, rad);
      census_row(r, y, census_r_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_r_), row_stride_r_, pad_left_);
    }
  }
  // Texture: |I(x+1) - I(x-1)| of the raw left image per padded column (x = c - r, clamped).
  if (texture_min_ > 0) {
    const int cols = row_stride_l_;
    for (int y = 0; y < h; ++y) {
      const std::uint8_t* row = l.ptr<std::uint8_t>(y);
      std::uint8_t* g = gradient_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(cols);
      // Columns of pixels 1..w-2 need no clamps (a loop that vectorises); the rest do.
      const int lo = std::min(rad + 1, cols), hi = std::max(lo, rad + w - 1);
      for (int c = 0; c < lo; ++c) g[c] = static_cast<std::uint8_t>(gradient_at(row, c, rad, w));
      for (int c = lo; c < hi; ++c) {
        g[c] = static_cast<std::uint8_t>(std::abs(int{row[c - rad + 1]} - int{row[c - rad - 1]}));
      }
      for (int c = hi; c < cols; ++c) g[c] = static_cast<std::uint8_t>(gradient_at(row, c, rad, w));
    }
  }
}

#if defined(__AVX2__)
namespace {

/// Column sums += scale * |l - r| of one row, in the fast row's storage order (its slide with
/// no outgoing row).
void add_sad_row_fast(std::uint16_t* column_sums, const std::uint8_t* lrow, const std::uint8_t* rrow,
                      int cols, int lanes, int scale) {
  const __m256i weights = _mm256_set1_epi16(static_cast<short>(scale));
  const __m256i zero = _mm256_setzero_si256();
  for (int c = 0; c < cols; ++c) {
    std::uint16_t* col = column_sums + static_cast<std::size_t>(c) * static_cast<std::size_t>(lanes);
    const __m256i l = _mm256_set1_epi8(static_cast<char>(lrow[c]));
    for (int i = 0; i < lanes; i += 32) {
      const __m256i r = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(rrow + c + i));
      const __m256i a = _mm256_or_si256(_mm256_subs_epu8(l, r), _mm256_subs_epu8(r, l));
      auto* s0 = reinterpret_cast<__m256i*>(col + i);
      auto* s1 = reinterpret_cast<__m256i*>(col + i + 16);
      _mm256_storeu_si256(s0, _mm256_add_epi16(_mm256_loadu_si256(s0), _mm256_maddubs_epi16(_mm256_unpacklo_epi8(a, zero), weights)));
      _mm256_storeu_si256(s1, _mm256_add_epi16(_mm256_loadu_si256(s1), _mm256_maddubs_epi16(_mm256_unpackhi_epi8(a, zero), weights)));
    }
  }
}

}  // namespace
#endif

bool BlockMatcher::fast_row() const { return fast_ && !portable_ && width_ <= kFieldStride; }

int BlockMatcher::column_scale() const { return fast_row() ? (lanes_ == 32 ? 4 : 8) : 1; }

void BlockMatcher::init_column_sums() {
  const int r = radius_, h = height_;
  const int cols = row_stride_l_, lanes = lanes_;
  const int block = 2 * r + 1;
  // The fast row's column sums are scaled and permuted in runs of 8 lanes (lane_at_position).
  const bool fast = fast_row();
  const int scale = column_scale();
  const auto run_at = [fast](int lane) { return static_cast<std::size_t>(fast ? lane_at_position(lane) : lane); };
  std::fill(column_sums_.begin(), column_sums_.end(), std::uint16_t{0});
  std::fill(texture_columns_.begin(), texture_columns_.end(), 0U);
  for (int k = -r; k <= r; ++k) {
    const int y = clampi(k, 0, h - 1);
    if (texture_min_ > 0) {
      const std::uint8_t* g = gradient_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(cols);
      for (int c = 0; c < cols; ++c) texture_columns_[static_cast<std::size_t>(c)] += g[c];
    }
    if (options_.cost == MatchingCost::kSad) {
      const std::uint8_t* lrow = left_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(cols);
      const std::uint8_t* rrow = right_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_r_);
#if defined(__AVX2__)
      if (fast_row()) {
        add_sad_row_fast(align64(column_sums_.data()), lrow, rrow, cols, lanes, column_scale());
        continue;
      }
#endif
      for (int c = 0; c < cols; ++c) {
        std::uint16_t* cs = align64(column_sums_.data()) + static_cast<std::size_t>(c) * static_cast<std::size_t>(lanes);
        for (int i0 = 0; i0 < lanes; i0 += 8) {  // the storage order keeps runs of 8 lanes
          std::uint16_t* sum = cs + run_at(i0);
          for (int i = 0; i < 8; ++i) {
            sum[i] = static_cast<std::uint16_t>(sum[i] + scale * std::abs(int{lrow[c]} - int{rrow[c + i0 + i]}));
          }
        }
      }
    } else {
      const std::uint64_t* lrow = census_l_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(cols);
      const std::uint64_t* rrow = census_r_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(row_stride_r_);
      const int slot = ((k % block) + block) % block;
      std::uint8_t* ring = cost_ring_.data() + static_cast<std::size_t>(slot) * static_cast<std::size_t>(cols) * static_cast<std::size_t>(lanes);
      for (int c = 0; c < cols; ++c) {
        std::uint16_t* cs = align64(column_sums_.data()) + static_cast<std::size_t>(c) * static_cast<std::size_t>(lanes);
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
  const bool fast = fast_row();
  const int scale = column_scale();
  const auto run_at = [fast](int lane) { return static_cast<std::size_t>(fast ? lane_at_position(lane) : lane); };
  const int k_new = y + r;
  const int y_new = std::min(k_new, h - 1);
  const int y_old = std::max(y - r - 1, 0);
  if (texture_min_ > 0) {
    const std::uint8_t* g_new = gradient_.data() + static_cast<std::size_t>(y_new) * static_cast<std::size_t>(cols);
    const std::uint8_t* g_old = gradient_.data() + static_cast<std::size_t>(y_old) * static_cast<std::size_t>(cols);
    std::uint32_t* tc = texture_columns_.data();
    for (int c = 0; c < cols; ++c) tc[c] += static_cast<std::uint32_t>(g_new[c]) - g_old[c];
  }
  const auto lane_stride = static_cast<std::size_t>(lanes);
  // SAD columns are slid by the row scan itself, just before it uses them.
  if (options_.cost == MatchingCost::kCensus) {
    const std::uint64_t* lrow = census_l_.data() + static_cast<std::size_t>(y_new) * static_cast<std::size_t>(cols);
    const std::uint64_t* rrow = census_r_.data() + static_cast<std::size_t>(y_new) * static_cast<std::size_t>(row_stride_r_);
    const int slot = k_new % block;  // the slot of row y-r-1 (same residue)
    std::uint8_t* ring = cost_ring_.data() + static_cast<std::size_t>(slot) * static_cast<std::size_t>(cols) * lane_stride;
    // The Hamming distances first (scalar popcnt), then the column and ring updates in loops
    // that vectorise.
    std::array<std::uint8_t, 1024> distances{};  // lanes <= 1024 (validate)
    for (int c = 0; c < cols; ++c) {
      std::uint16_t* cs = align64(column_sums_.data()) + static_cast<std::size_t>(c) * lane_stride;
      std::uint8_t* rc = ring + static_cast<std::size_t>(c) * lane_stride;
      const std::uint64_t lc = lrow[c];
      for (int i = 0; i < lanes; ++i) {
        distances[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(std::popcount(lc ^ rrow[c + i]));
      }
      for (int i0 = 0; i0 < lanes; i0 += 8) {
        std::uint16_t* sum = cs + run_at(i0);
        for (int i = 0; i < 8; ++i) {
          sum[i] = static_cast<std::uint16_t>(sum[i] + scale * (distances[static_cast<std::size_t>(i0 + i)] - rc[i0 + i]));
        }
      }
      std::memcpy(rc, distances.data(), lane_stride);
    }
  }
}

namespace {

// Row-scan outcome per pixel, before the left-right check and the depth range.
enum RowState : std::uint8_t { kCandidate = 0, kUnreachable, kLowTexture, kNotUnique };

/// Everything one row scan reads and writes. Lanes below first(x) = max(lanes - num,
/// d_top - x) are out of range (d >= max_disparity, or d > x: outside the right image).
struct RowScan {
  std::uint16_t* column_sums;  // cols x lanes: slid to this row, or by the scan (slide_*)
  const std::uint32_t* texture_columns;
  int width, radius, lanes, num, d_top, uniqueness;
  std::uint32_t texture_min;
  std::uint16_t* volume;      // width x lanes: the box costs of the row (for checks)
  std::uint16_t* right_min;   // width + lanes: best cost of right pixel xr at xr + d_top
  std::int32_t* winner_lane;  // width
  std::uint8_t* state;        // width
  // SAD: the scan slides column x + 2r down one row itself (row in: *_new, row out: *_old)
  // just before using it. Null: the column sums are already slid (census, first row).
  const std::uint8_t* left_new = nullptr;
  const std::uint8_t* left_old = nullptr;
  const std::uint8_t* right_new = nullptr;
  const std::uint8_t* right_old = nullptr;

  [[nodiscard]] int first_lane(int x) const { return std::max(lanes - num, d_top - x); }
};

/// The portable scan: the same results as the AVX2 one, one lane at a time.
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

#if defined(__AVX2__)
KESTREL_INLINE inline __m256i load_lanes(const std::uint16_t* p) {
  return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
}
KESTREL_INLINE inline void store_lanes(std::uint16_t* p, __m256i v) {
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), v);
}

/// scan_row_avx2's state along one row (lanes = 16 NV): the box costs, the right view's
/// running minima and the window's texture sum, all kept in registers. Its helpers are left
/// to the inliner (which inlines them all): forcing it changes how GCC peels and unswitches
/// the pixel loops.
template <int NV>
struct Avx2Scan {
  explicit Avx2Scan(const RowScan& row)
      : s(row),
        L(static_cast<std::size_t>(row.lanes)),
        block(2 * row.radius + 1),
        cs(row.column_sums),
        slide(row.left_new != nullptr) {}

  const RowScan& s;
  std::size_t L;
  int block;
  std::uint16_t* cs;
  bool slide;  // SAD: the scan slides the column sums itself
  __m256i box[NV], win[NV];
  std::uint32_t tex;
};

/// Column c slid down one row, returned in registers and stored (SAD only).
template <int NV>
inline void avx2_slide_column(const Avx2Scan<NV>& t, int c, __m256i* out) {
  const RowScan& s = t.s;
  std::uint16_t* col = t.cs + static_cast<std::size_t>(c) * t.L;
  if (!t.slide) {
    for (int i = 0; i < NV; ++i) out[i] = load_lanes(col + 16 * i);
    return;
  }
  const __m256i vln = _mm256_set1_epi8(static_cast<char>(s.left_new[c]));
  const __m256i vlo = _mm256_set1_epi8(static_cast<char>(s.left_old[c]));
  for (int i = 0; i < NV; i += 2) {
    const __m256i r_new =
        _mm256_loadu_si256(reinterpret_cast<const __m256i*>(s.right_new + c + 16 * i));
    const __m256i r_old =
        _mm256_loadu_si256(reinterpret_cast<const __m256i*>(s.right_old + c + 16 * i));
    const __m256i a_new =
        _mm256_or_si256(_mm256_subs_epu8(vln, r_new), _mm256_subs_epu8(r_new, vln));
    const __m256i a_old =
        _mm256_or_si256(_mm256_subs_epu8(vlo, r_old), _mm256_subs_epu8(r_old, vlo));
    __m256i s0 = load_lanes(col + 16 * i);
    __m256i s1 = load_lanes(col + 16 * i + 16);
    s0 = _mm256_add_epi16(s0, _mm256_cvtepu8_epi16(_mm256_castsi256_si128(a_new)));
    s0 = _mm256_sub_epi16(s0, _mm256_cvtepu8_epi16(_mm256_castsi256_si128(a_old)));
    s1 = _mm256_add_epi16(s1, _mm256_cvtepu8_epi16(_mm256_extracti128_si256(a_new, 1)));
    s1 = _mm256_sub_epi16(s1, _mm256_cvtepu8_epi16(_mm256_extracti128_si256(a_old, 1)));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(col + 16 * i), s0);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(col + 16 * i + 16), s1);
    out[i] = s0;
    out[i + 1] = s1;
  }
}

/// The box and texture sum of pixel 0's window (columns 0 .. 2r), the right view's minima
/// empty.
template <int NV>
inline void avx2_scan_begin(Avx2Scan<NV>& t) {
  const __m256i ones = _mm256_set1_epi16(-1);
  for (int i = 0; i < NV; ++i) {
    t.box[i] = _mm256_setzero_si256();
    t.win[i] = ones;
  }
  t.tex = 0;
  for (int c = 0; c < t.block; ++c) {
    __m256i col[NV];
    avx2_slide_column(t, c, col);
    for (int i = 0; i < NV; ++i) t.box[i] = _mm256_add_epi16(t.box[i], col[i]);
    t.tex += t.s.texture_columns[c];
  }
}

/// Pixel x: slide the box, store it in the volume, fold it into the right view's minima, and
/// the winner and the row scan's checks. kMasked: lanes below first_lane(x) are out of range.
template <bool kMasked, int NV>
inline void avx2_scan_pixel(Avx2Scan<NV>& t, int x) {
  const RowScan& s = t.s;
  const __m256i ones = _mm256_set1_epi16(-1);
  const __m256i iota = _mm256_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m256i two = _mm256_set1_epi16(2);
  if (x > 0) {
    __m256i add[NV];
    avx2_slide_column(t, x + 2 * s.radius, add);
    const std::uint16_t* sub = t.cs + static_cast<std::size_t>(x - 1) * t.L;
    for (int i = 0; i < NV; ++i) {
      t.box[i] = _mm256_sub_epi16(_mm256_add_epi16(t.box[i], add[i]), load_lanes(sub + 16 * i));
    }
    t.tex += s.texture_columns[x + 2 * s.radius] - s.texture_columns[x - 1];
  }
  std::uint16_t* vol = s.volume + static_cast<std::size_t>(x) * t.L;
  for (int i = 0; i < NV; ++i) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(vol + 16 * i), t.box[i]);
  }
  const int first = kMasked ? s.first_lane(x) : 0;
  __m256i v[NV];
  for (int i = 0; i < NV; ++i) {
    if constexpr (kMasked) {
      const __m256i f = _mm256_set1_epi16(static_cast<short>(first - 16 * i));
      v[i] = _mm256_or_si256(t.box[i], _mm256_cmpgt_epi16(f, iota));
    } else {
      v[i] = t.box[i];
    }
  }
  // Right view: lane k holds right pixel x - d_top + k; lane 0 is complete after this x.
  for (int i = 0; i < NV; ++i) t.win[i] = _mm256_min_epu16(t.win[i], v[i]);
  s.right_min[x] = static_cast<std::uint16_t>(_mm256_extract_epi16(t.win[0], 0));
  for (int i = 0; i < NV; ++i) {
    const __m256i next = i + 1 < NV ? t.win[i + 1] : ones;
    t.win[i] = _mm256_alignr_epi8(_mm256_permute2x128_si256(t.win[i], next, 0x21), t.win[i], 2);
  }
  s.winner_lane[x] = -1;
  if (kMasked && first >= s.lanes) {
    s.state[x] = kUnreachable;
    return;
  }
  __m256i m = v[0];
  for (int i = 1; i < NV; ++i) m = _mm256_min_epu16(m, v[i]);
  const __m128i m8 = _mm_min_epu16(_mm256_castsi256_si128(m), _mm256_extracti128_si256(m, 1));
  const int c0 = _mm_extract_epi16(_mm_minpos_epu16(m8), 0);
  const __m256i target = _mm256_set1_epi16(static_cast<short>(c0));
  int best = 0;
  for (int i = 0; i < NV; i += 2) {
    const auto lo =
        static_cast<std::uint32_t>(_mm256_movemask_epi8(_mm256_cmpeq_epi16(v[i], target)));
    const auto hi =
        static_cast<std::uint32_t>(_mm256_movemask_epi8(_mm256_cmpeq_epi16(v[i + 1], target)));
    const std::uint64_t mask = lo | (static_cast<std::uint64_t>(hi) << 32);
    if (mask != 0) {
      best = 16 * i + std::countr_zero(mask) / 2;
      break;
    }
  }
  if (t.tex < s.texture_min) {
    s.state[x] = kLowTexture;
    return;
  }
  if (s.uniqueness > 0) {
    // Lanes within 1 of the winner: (k - (best - 1)) as unsigned <= 2.
    __m256i m2 = ones;
    for (int i = 0; i < NV; ++i) {
      const __m256i d =
          _mm256_sub_epi16(iota, _mm256_set1_epi16(static_cast<short>(best - 1 - 16 * i)));
      const __m256i near = _mm256_cmpeq_epi16(_mm256_min_epu16(d, two), d);
      m2 = _mm256_min_epu16(m2, _mm256_or_si256(v[i], near));
    }
    const __m128i s8 = _mm_min_epu16(_mm256_castsi256_si128(m2), _mm256_extracti128_si256(m2, 1));
    const int second = _mm_extract_epi16(_mm_minpos_epu16(s8), 0);
    if (second * 100 <= c0 * (100 + s.uniqueness)) {
      s.state[x] = kNotUnique;
      return;
    }
  }
  s.state[x] = kCandidate;
  s.winner_lane[x] = best;
}

/// The AVX2 scan for lanes = 16 NV: the box costs, the right view's running minima and the
/// winner search stay in registers; the right view's window slides down one lane per pixel.
template <int NV>
void scan_row_avx2(const RowScan& s) {
  Avx2Scan<NV> t(s);
  avx2_scan_begin(t);
  // Pixels x < x_full have out-of-range lanes (first_lane(x) > 0) that must be masked.
  const int x_full = s.lanes > s.num ? s.width : std::min(s.width, std::max(0, s.d_top + 1));
  for (int x = 0; x < x_full; ++x) avx2_scan_pixel<true>(t, x);
  for (int x = x_full; x < s.width; ++x) avx2_scan_pixel<false>(t, x);
  // Right pixels not yet emitted: lane k now holds right pixel width - d_top + k.
  for (int i = 0; i < NV; ++i) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(s.right_min + s.width + 16 * i), t.win[i]);
  }
  // Columns past the last window (x + 2r > width - 1 + 2r never happens): all were slid.
}

struct FastRow {
  std::uint16_t* ring;              // kRingSlots slots: tagged box costs of pixel x at x % slots
  std::uint16_t* fields;            // kFieldCount x kFieldStride
  const std::uint16_t* near_masks;  // lanes x lanes: 0xFFFF at the positions of lanes b-1..b+1
  const std::int16_t* position;     // lane -> position in a slot, lanes -kRingGuard..lanes+15
  int lr_max_diff;
  bool subpixel, census;
  float d_min, d_max;
};

/// How the fast row gets its column sums: already slid (census, first row), or slid by the
/// row itself from the SAD rows.
enum class Slide { kNone, kSad };

/// scan_row_fast's state along one row, for 32 or 64 lanes (NV = 2 or 4 registers). The
/// structs' fields are copied in, as locals: the per-pixel stores could alias the structs'
/// fields, which would make the compiler reload them for every pixel. Its fields go to
/// std::min and std::max as copies: those take references, and a reference to a field keeps
/// the whole state in memory instead of in registers.
template <int NV, Slide kSlide>
struct FastScan {
  static constexpr int L = 16 * NV;
  static constexpr int kBits = NV == 2 ? 2 : 3;
  // A ring slot: guard lanes, the lanes, guard lanes.
  static constexpr int kSlot = L + 2 * kRingGuard;
  int w, r, num, d_top, lr, lane_floor;
  bool lr_check, uniqueness;
  std::uint16_t* cs;
  std::uint16_t* right_min;
  std::uint16_t* ring;
  std::uint16_t* fields;
  const std::uint16_t* near_masks;
  const std::int16_t* position;
  const std::uint8_t* left_new;
  const std::uint8_t* left_old;
  const std::uint8_t* right_new;
  const std::uint8_t* right_old;
  // Storage order (see lane_at_position): vector 2g + v holds lanes 32g + 8v + {0..7} in its
  // low half and 32g + 16 + 8v + {0..7} in its high half.
  __m256i lane_of[NV], box[NV], win[NV];
};

/// Position 0 of pixel x's slot. Pixels -lr..-1 and w..w+lr-1 read as masked.
template <int NV, Slide kSlide>
KESTREL_INLINE inline std::uint16_t* fast_ring_at(const FastScan<NV, kSlide>& t, int x) {
  return t.ring + static_cast<std::size_t>(x & (kRingSlots - 1)) * FastScan<NV, kSlide>::kSlot +
         kRingGuard;
}

/// Column c slid down one row (kSlide), in registers and stored back.
template <int NV, Slide kSlide>
KESTREL_INLINE inline void fast_slide_column(const FastScan<NV, kSlide>& t, int c, __m256i* out) {
  std::uint16_t* col = t.cs + static_cast<std::size_t>(c) * FastScan<NV, kSlide>::L;
  if constexpr (kSlide == Slide::kNone) {
    for (int i = 0; i < NV; ++i) out[i] = load_lanes(col + 16 * i);
  } else {
    // 2^kBits (|l - r| of the new row - |l - r| of the old one), 32 lanes at a time:
    // pmaddubsw on the interleaved costs (weights 2^kBits, -2^kBits) subtracts, widens and
    // scales in one step (|result| <= 8 * 255, no saturation) and yields the storage order
    // directly.
    constexpr int kScale = 1 << FastScan<NV, kSlide>::kBits;
    const __m256i weights = _mm256_set1_epi16(static_cast<short>(((256 - kScale) << 8) | kScale));
    const __m256i vln = _mm256_set1_epi8(static_cast<char>(t.left_new[c]));
    const __m256i vlo = _mm256_set1_epi8(static_cast<char>(t.left_old[c]));
    for (int i = 0; i < NV; i += 2) {
      const __m256i r_new =
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(t.right_new + c + 16 * i));
      const __m256i r_old =
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(t.right_old + c + 16 * i));
      const __m256i a_new =
          _mm256_or_si256(_mm256_subs_epu8(vln, r_new), _mm256_subs_epu8(r_new, vln));
      const __m256i a_old =
          _mm256_or_si256(_mm256_subs_epu8(vlo, r_old), _mm256_subs_epu8(r_old, vlo));
      const __m256i s0 =
          _mm256_add_epi16(load_lanes(col + 16 * i),
                           _mm256_maddubs_epi16(_mm256_unpacklo_epi8(a_new, a_old), weights));
      const __m256i s1 =
          _mm256_add_epi16(load_lanes(col + 16 * i + 16),
                           _mm256_maddubs_epi16(_mm256_unpackhi_epi8(a_new, a_old), weights));
      store_lanes(col + 16 * i, s0);
      store_lanes(col + 16 * i + 16, s1);
      out[i] = s0;
      out[i + 1] = s1;
    }
  }
}

/// The row's state from the structs, the guard slots of pixels -kFastMaxLrDiff..-1, and the
/// tagged box of pixel 0's window (columns 0 .. 2r).
template <int NV, Slide kSlide>
KESTREL_INLINE inline void fast_scan_begin(FastScan<NV, kSlide>& t, const RowScan& s,
                                           const FastRow& f) {
  t.w = s.width;
  t.r = s.radius;
  t.num = s.num;
  t.d_top = s.d_top;
  t.lr = f.lr_max_diff;
  t.lr_check = t.lr >= 0;
  t.uniqueness = s.uniqueness > 0;
  t.cs = s.column_sums;
  t.right_min = s.right_min;
  t.ring = f.ring;
  t.fields = f.fields;
  t.near_masks = f.near_masks;
  t.position = f.position;
  t.left_new = s.left_new;
  t.left_old = s.left_old;
  t.right_new = s.right_new;
  t.right_old = s.right_old;
  t.lane_floor = FastScan<NV, kSlide>::L - t.num;
  const __m256i ones = _mm256_set1_epi16(-1);
  for (int x = -kFastMaxLrDiff; x < 0; ++x) {
    for (int i = 0; i < NV; ++i) store_lanes(fast_ring_at(t, x) + 16 * i, ones);
  }
  for (int i = 0; i < NV; ++i) {
    alignas(32) std::int16_t lanes_here[16];
    for (int k = 0; k < 16; ++k) {
      lanes_here[k] = static_cast<std::int16_t>(lane_at_position(16 * i + k));
    }
    t.lane_of[i] = _mm256_load_si256(reinterpret_cast<const __m256i*>(lanes_here));
    // The tag lane / 8 in the low bits: the costs themselves are stored times 2^kBits.
    t.box[i] = _mm256_srli_epi16(t.lane_of[i], 3);
    t.win[i] = ones;
  }
  for (int c = 0; c <= 2 * t.r; ++c) {
    __m256i col[NV];
    fast_slide_column(t, c, col);
    for (int i = 0; i < NV; ++i) t.box[i] = _mm256_add_epi16(t.box[i], col[i]);
  }
}

/// The winner of pixel x: cost and first lane from one fold and one phminposuw (tagged costs).
template <int NV, Slide kSlide>
KESTREL_INLINE inline void fast_store_winner(const FastScan<NV, kSlide>& t, int x,
                                             const __m256i* v) {
  constexpr int kBits = FastScan<NV, kSlide>::kBits;
  __m256i m = v[0];
  for (int i = 1; i < NV; ++i) m = _mm256_min_epu16(m, v[i]);
  const __m128i m8 = _mm_min_epu16(_mm256_castsi256_si128(m), _mm256_extracti128_si256(m, 1));
  const auto mp = static_cast<std::uint32_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(m8)));
  const std::uint32_t tagged = mp & 0xFFFFU;
  t.fields[kFieldCost * kFieldStride + x] = static_cast<std::uint16_t>(tagged);
  t.fields[kFieldBest * kFieldStride + x] =
      static_cast<std::uint16_t>(((tagged & ((1U << kBits) - 1U)) << 3) | ((mp >> 16) & 7U));
}

/// Right view: lane k holds right pixel x - d_top + k; lane 0 (position 0) is complete after
/// this x. The window then moves down one lane: in storage order the low vector of a group
/// takes the high one's first lane of each half, the high vector takes the low vector's
/// second half and the next group's first.
template <int NV, Slide kSlide>
KESTREL_INLINE inline void fast_fold_right(FastScan<NV, kSlide>& t, int x, const __m256i* v) {
  const __m256i ones = _mm256_set1_epi16(-1);
  for (int i = 0; i < NV; ++i) t.win[i] = _mm256_min_epu16(t.win[i], v[i]);
  t.right_min[x] = static_cast<std::uint16_t>(_mm256_extract_epi16(t.win[0], 0));
  for (int g = 0; g < NV / 2; ++g) {
    const __m256i a = t.win[2 * g], b = t.win[2 * g + 1];
    const __m256i next = 2 * g + 2 < NV ? t.win[2 * g + 2] : ones;
    t.win[2 * g] = _mm256_alignr_epi8(b, a, 2);
    t.win[2 * g + 1] = _mm256_alignr_epi8(_mm256_permute2x128_si256(a, next, 0x21), b, 2);
  }
}

/// Stage 1, pixel x: slide its new column, update the box, store the (masked) box costs in
/// the ring, find the winner, and fold the costs into the right view's minima.
template <bool kMasked, int NV, Slide kSlide>
KESTREL_INLINE inline void fast_scan_pixel(FastScan<NV, kSlide>& t, int x) {
  if (x > 0) {
    __m256i add[NV];
    fast_slide_column(t, x + 2 * t.r, add);
    const std::uint16_t* sub = t.cs + static_cast<std::size_t>(x - 1) * FastScan<NV, kSlide>::L;
    for (int i = 0; i < NV; ++i) {
      t.box[i] = _mm256_sub_epi16(_mm256_add_epi16(t.box[i], add[i]), load_lanes(sub + 16 * i));
    }
  }
  __m256i v[NV];
  if constexpr (kMasked) {  // lanes below first_lane(x) are out of range
    const int lane_floor = t.lane_floor;
    const __m256i first = _mm256_set1_epi16(static_cast<short>(std::max(lane_floor, t.d_top - x)));
    for (int i = 0; i < NV; ++i) {
      v[i] = _mm256_or_si256(t.box[i], _mm256_cmpgt_epi16(first, t.lane_of[i]));
    }
  } else {
    for (int i = 0; i < NV; ++i) v[i] = t.box[i];
  }
  std::uint16_t* slot = fast_ring_at(t, x);
  for (int i = 0; i < NV; ++i) store_lanes(slot + 16 * i, v[i]);
  fast_store_winner(t, x, v);
  if (t.lr_check) fast_fold_right(t, x, v);
}

/// Stage 2, pixel q = x - kLag: what the checks and the fit need around the winner, read
/// back from the ring and the fields. Kept apart from stage 1 so that its dependency chain
/// (winner -> mask -> second minimum) starts from stored inputs and overlaps the next
/// pixels' stage 1, and so that its 16-bit loads find the 256-bit ring stores in the cache
/// (a load from a store still in flight that it does not match cannot be forwarded and
/// stalls). Masked lanes and the guard lanes and slots read as 0xFFFF, above every cost, so
/// the reads need no range checks: a minimum ignores them and the fit is not made there.
template <int NV, Slide kSlide>
KESTREL_INLINE inline void fast_check_pixel(const FastScan<NV, kSlide>& t, int q) {
  const std::uint16_t* slot = fast_ring_at(t, q);
  std::uint16_t* fq = t.fields + q;
  const int best = fq[kFieldBest * kFieldStride];
  if (t.uniqueness) {
    // The least cost of the lanes further than 1 from the winner (all masked: 0xFFFF).
    const std::uint16_t* nm =
        t.near_masks + static_cast<std::size_t>(best) * FastScan<NV, kSlide>::L;
    __m256i m2 = _mm256_or_si256(load_lanes(slot), load_lanes(nm));
    for (int i = 1; i < NV; ++i) {
      const __m256i far = _mm256_or_si256(load_lanes(slot + 16 * i), load_lanes(nm + 16 * i));
      m2 = _mm256_min_epu16(m2, far);
    }
    const __m128i s8 = _mm_min_epu16(_mm256_castsi256_si128(m2), _mm256_extracti128_si256(m2, 1));
    fq[kFieldSecond * kFieldStride] =
        static_cast<std::uint16_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(s8)));
  }
  const int at_minus = t.position[best + 1], at_plus = t.position[best - 1];
  fq[kFieldMinus * kFieldStride] = slot[at_minus];
  fq[kFieldPlus * kFieldStride] = slot[at_plus];
  if (t.lr_check) {
    // The right pixel q - d's diagonal: pixel q + j at lane best - j, |j| <= lr.
    std::uint16_t diag = fq[kFieldCost * kFieldStride];
    if (t.lr == 1) {  // the default: the positions are the fit's
      diag = std::min(diag,
                      std::min(fast_ring_at(t, q + 1)[at_plus], fast_ring_at(t, q - 1)[at_minus]));
    } else {
      for (int j = 1; j <= t.lr; ++j) {
        diag = std::min(diag, std::min(fast_ring_at(t, q + j)[t.position[best - j]],
                                       fast_ring_at(t, q - j)[t.position[best + j]]));
      }
    }
    fq[kFieldDiag * kFieldStride] = diag;
  }
}

/// The last kLag pixels' stage 2, then the right view's last minima.
template <int NV, Slide kSlide>
KESTREL_INLINE inline void fast_scan_end(const FastScan<NV, kSlide>& t) {
  constexpr int L = FastScan<NV, kSlide>::L;
  const int w = t.w;
  const __m256i ones = _mm256_set1_epi16(-1);
  // The guard slots of pixels w.. overwrite pixels w - kRingSlots.., which only the pixels
  // before q_guard still read.
  const int q_guard = std::max(0, w - kFastMaxLrDiff);
  for (int q = std::max(0, w - kLag); q < q_guard; ++q) fast_check_pixel(t, q);
  for (int x = w; x < w + kFastMaxLrDiff; ++x) {
    for (int i = 0; i < NV; ++i) store_lanes(fast_ring_at(t, x) + 16 * i, ones);
  }
  for (int q = std::max(q_guard, w - kLag); q < w; ++q) fast_check_pixel(t, q);
  if (t.lr_check) {  // right pixels w - d_top + k, k < L: back to lane order
    alignas(32) std::uint16_t rest[L];
    for (int i = 0; i < NV; ++i) {
      _mm256_store_si256(reinterpret_cast<__m256i*>(rest + 16 * i), t.win[i]);
    }
    for (int k = 0; k < L; ++k) t.right_min[w + k] = rest[t.position[k]];
  }
}

/// The scan of one row for 32 or 64 lanes (NV = 2 or 4 registers). Box costs are TAGGED:
/// 2^kBits * cost + lane / 8, so that the 8-way fold of the lanes (lane = 8 m + j) and one
/// phminposuw give the best cost and the FIRST lane that reaches it: the order of (tagged
/// value, j) is the order of (cost, lane). Per pixel it leaves the fields of FastField.
template <int NV, Slide kSlide>
void scan_row_fast(const RowScan& s, const FastRow& f) {
  FastScan<NV, kSlide> t;
  fast_scan_begin(t, s, f);
  const int w = t.w, num = t.num, d_top = t.d_top;
  const int x_full = FastScan<NV, kSlide>::L > num ? w : std::min(w, std::max(0, d_top + 1));
  for (int x = 0; x < x_full; ++x) {
    fast_scan_pixel<true>(t, x);
    if (x >= kLag) fast_check_pixel(t, x - kLag);
  }
  for (int x = x_full; x < w; ++x) {
    fast_scan_pixel<false>(t, x);
    if (x >= kLag) fast_check_pixel(t, x - kLag);
  }
  fast_scan_end(t);
}

/// finish_row_fast's kChecks: which checks are on, so that each combination is its own loop.
constexpr int kFinishTexture = 1, kFinishUnique = 2, kFinishLr = 4, kFinishSubpixel = 8;

/// finish_row_fast's inputs, as locals (see FastScan).
struct FastFinish {
  int w, lanes, d_top, lane_floor, min_d, uniqueness, block;
  bool census;
  const std::uint16_t* fields;
  const std::uint16_t* right_min;
  const std::uint32_t* texture_columns;
  std::uint32_t texture_min;
  float d_min, d_max;
  __m256i texture_min8;
  __m256 d_min8, d_max8;
};

/// The rejections and the valid pixels, eight lanes of counts each.
struct FastFinishCounts {
  __m256i unreach, tex, uniq, lr, depth, valid;
};

/// Field `which` of pixels p .. p + 7, widened to 32 bits.
KESTREL_INLINE inline __m256i fast_field8(const std::uint16_t* fields, int which, int p) {
  return _mm256_cvtepu16_epi32(
      _mm_loadu_si128(reinterpret_cast<const __m128i*>(fields + which * kFieldStride + p)));
}

template <int kBits>
KESTREL_INLINE inline __m256i fast_cost8(const std::uint16_t* fields, int which, int p) {
  return _mm256_srli_epi32(fast_field8(fields, which, p), kBits);
}

/// The window sums of texture columns p .. p + 2r for pixels p .. p + 7 (below 2^31: a signed
/// compare).
KESTREL_INLINE inline __m256i fast_texture8(const FastFinish& t, int p) {
  __m256i tex = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(t.texture_columns + p));
  for (int c = 1; c < t.block; ++c) {
    tex = _mm256_add_epi32(
        tex, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(t.texture_columns + p + c)));
  }
  return tex;
}

/// Subpixel offsets of pixels pix = p .. p + 7: both neighbours in range and a nonzero cost,
/// as in finish_row.
template <int kBits>
KESTREL_INLINE inline __m256 fast_subpixel8(const FastFinish& t, int p, __m256i pix, __m256i best,
                                            __m256i c0) {
  const __m256i zero = _mm256_setzero_si256();
  const __m256i cm = fast_cost8<kBits>(t.fields, kFieldMinus, p),
                cp = fast_cost8<kBits>(t.fields, kFieldPlus, p);
  const __m256i first = _mm256_max_epi32(_mm256_set1_epi32(t.lane_floor),
                                         _mm256_sub_epi32(_mm256_set1_epi32(t.d_top), pix));
  __m256i fit = _mm256_cmpgt_epi32(c0, zero);
  fit = _mm256_and_si256(fit, _mm256_cmpgt_epi32(_mm256_set1_epi32(t.lanes - 1), best));
  fit = _mm256_andnot_si256(_mm256_cmpgt_epi32(first, _mm256_sub_epi32(best, _mm256_set1_epi32(1))),
                            fit);
  const __m256i denom = t.census
                            ? _mm256_sub_epi32(_mm256_add_epi32(cm, cp), _mm256_add_epi32(c0, c0))
                            : _mm256_sub_epi32(_mm256_max_epi32(cm, cp), c0);
  fit = _mm256_and_si256(fit, _mm256_cmpgt_epi32(denom, zero));
  const __m256i numer = _mm256_and_si256(fit, _mm256_sub_epi32(cm, cp));
  const __m256i den = _mm256_blendv_epi8(_mm256_set1_epi32(1), _mm256_add_epi32(denom, denom), fit);
  return _mm256_div_ps(_mm256_cvtepi32_ps(numer), _mm256_cvtepi32_ps(den));
}

/// Pixels p .. p + 7: each counts once, under its first failing check; the disparity where
/// none fails.
template <int kBits, int kChecks>
KESTREL_INLINE inline void fast_finish8(const FastFinish& t, int p, float* out,
                                        FastFinishCounts& n) {
  constexpr bool lr_check = (kChecks & kFinishLr) != 0, texture = (kChecks & kFinishTexture) != 0;
  constexpr bool subpixel = (kChecks & kFinishSubpixel) != 0;
  const __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i zero = _mm256_setzero_si256(), all = _mm256_set1_epi32(-1);
  const __m256 inf = _mm256_set1_ps(kNoDisparity);
  const __m256i pix = _mm256_add_epi32(_mm256_set1_epi32(p), iota);
  const __m256i best = fast_field8(t.fields, kFieldBest, p);
  const __m256i c0 = fast_cost8<kBits>(t.fields, kFieldCost, p);
  const __m256i unreach = _mm256_cmpgt_epi32(_mm256_set1_epi32(t.min_d), pix);
  __m256i open = _mm256_xor_si256(unreach, all);
  __m256i low_tex = zero, not_unique = zero, lr_fail = zero;
  if constexpr (texture) {
    low_tex = _mm256_and_si256(open, _mm256_cmpgt_epi32(t.texture_min8, fast_texture8(t, p)));
    open = _mm256_andnot_si256(low_tex, open);
  }
  if constexpr ((kChecks & kFinishUnique) != 0) {
    // second * 100 <= c0 * (100 + u), where there is a second.
    const __m256i second = fast_field8(t.fields, kFieldSecond, p);
    const __m256i some =
        _mm256_xor_si256(_mm256_cmpeq_epi32(second, _mm256_set1_epi32(0xFFFF)), all);
    const __m256i lhs =
        _mm256_mullo_epi32(_mm256_srli_epi32(second, kBits), _mm256_set1_epi32(100));
    const __m256i rhs = _mm256_mullo_epi32(c0, _mm256_set1_epi32(100 + t.uniqueness));
    const __m256i fails = _mm256_andnot_si256(_mm256_cmpgt_epi32(lhs, rhs), some);
    not_unique = _mm256_and_si256(open, fails);
    open = _mm256_andnot_si256(not_unique, open);
  }
  if constexpr (lr_check) {
    // right_min[p + best] (uint16, read as the low half of a 32-bit gather).
    const __m256i right = _mm256_i32gather_epi32(reinterpret_cast<const int*>(t.right_min),
                                                 _mm256_add_epi32(pix, best), 2);
    const __m256i right_best =
        _mm256_srli_epi32(_mm256_and_si256(right, _mm256_set1_epi32(0xFFFF)), kBits);
    lr_fail = _mm256_and_si256(
        open, _mm256_cmpgt_epi32(fast_cost8<kBits>(t.fields, kFieldDiag, p), right_best));
    open = _mm256_andnot_si256(lr_fail, open);
  }
  __m256 delta = _mm256_setzero_ps();
  if constexpr (subpixel) delta = fast_subpixel8<kBits>(t, p, pix, best, c0);
  const __m256 ds =
      _mm256_add_ps(_mm256_cvtepi32_ps(_mm256_sub_epi32(_mm256_set1_epi32(t.d_top), best)), delta);
  const __m256i out_of_range = _mm256_castps_si256(_mm256_or_ps(
      _mm256_cmp_ps(ds, t.d_min8, _CMP_LT_OQ), _mm256_cmp_ps(ds, t.d_max8, _CMP_GT_OQ)));
  const __m256i depth_fail = _mm256_and_si256(open, out_of_range);
  open = _mm256_andnot_si256(depth_fail, open);
  _mm256_storeu_ps(out + p, _mm256_blendv_ps(inf, ds, _mm256_castsi256_ps(open)));
  n.unreach = _mm256_sub_epi32(n.unreach, unreach);
  n.tex = _mm256_sub_epi32(n.tex, low_tex);
  n.uniq = _mm256_sub_epi32(n.uniq, not_unique);
  n.lr = _mm256_sub_epi32(n.lr, lr_fail);
  n.depth = _mm256_sub_epi32(n.depth, depth_fail);
  n.valid = _mm256_sub_epi32(n.valid, open);
}

inline void add_fast_finish_counts(const FastFinishCounts& n, MatchStats& stats) {
  const auto sum = [](__m256i v) {
    alignas(32) std::int32_t a[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(a), v);
    return static_cast<std::size_t>(a[0] + a[1] + a[2] + a[3] + a[4] + a[5] + a[6] + a[7]);
  };
  stats.unreachable += sum(n.unreach);
  stats.rejected_texture += sum(n.tex);
  stats.rejected_uniqueness += sum(n.uniq);
  stats.rejected_lr += sum(n.lr);
  stats.rejected_depth += sum(n.depth);
  stats.valid += sum(n.valid);
}

/// Pixel p alone (the last width % 8 pixels), with the same checks and arithmetic.
template <int kBits, int kChecks>
KESTREL_INLINE inline void fast_finish1(const FastFinish& t, int p, float* out, MatchStats& stats) {
  constexpr bool lr_check = (kChecks & kFinishLr) != 0, texture = (kChecks & kFinishTexture) != 0;
  constexpr bool subpixel = (kChecks & kFinishSubpixel) != 0;
  out[p] = kNoDisparity;
  const std::uint16_t* fp = t.fields + p;
  if (p < t.min_d) {
    ++stats.unreachable;
    return;
  }
  if constexpr (texture) {
    std::uint32_t tex = 0;
    for (int c = 0; c < t.block; ++c) tex += t.texture_columns[p + c];
    if (tex < t.texture_min) {
      ++stats.rejected_texture;
      return;
    }
  }
  const int best = fp[kFieldBest * kFieldStride], c0 = fp[kFieldCost * kFieldStride] >> kBits;
  const int second = fp[kFieldSecond * kFieldStride];
  if (t.uniqueness > 0 && second != 0xFFFF &&
      (second >> kBits) * 100 <= c0 * (100 + t.uniqueness)) {
    ++stats.rejected_uniqueness;
    return;
  }
  if (lr_check && (fp[kFieldDiag * kFieldStride] >> kBits) > (t.right_min[p + best] >> kBits)) {
    ++stats.rejected_lr;
    return;
  }
  float delta = 0.0F;
  const int lane_floor = t.lane_floor;
  const int first = std::max(lane_floor, t.d_top - p);
  if (subpixel && c0 > 0 && best + 1 < t.lanes && best - 1 >= first) {
    const int cm = fp[kFieldMinus * kFieldStride] >> kBits,
              cp = fp[kFieldPlus * kFieldStride] >> kBits;
    const int denom = t.census ? cm + cp - 2 * c0 : std::max(cm, cp) - c0;
    if (denom > 0) delta = static_cast<float>(cm - cp) / static_cast<float>(2 * denom);
  }
  const float ds = static_cast<float>(t.d_top - best) + delta;
  if (ds < t.d_min || ds > t.d_max) {
    ++stats.rejected_depth;
    return;
  }
  out[p] = ds;
  ++stats.valid;
}

/// Disparities of one row from the fields scan_row_fast left: the checks in finish_row's
/// order (unreachable, texture, uniqueness, left-right, depth range) and the subpixel fit,
/// eight pixels at a time, with finish_row's arithmetic (float division included): the same
/// bits. The texture sum of a window is added up here from the column sums.
template <int kBits, int kChecks>
void finish_row_fast(const RowScan& s, const FastRow& f, float* out, MatchStats& stats) {
  const FastFinish t{.w = s.width,
                     .lanes = s.lanes,
                     .d_top = s.d_top,
                     .lane_floor = s.lanes - s.num,
                     .min_d = s.d_top - s.lanes + 1,
                     .uniqueness = (kChecks & kFinishUnique) != 0 ? s.uniqueness : 0,
                     .block = 2 * s.radius + 1,
                     .census = f.census,
                     .fields = f.fields,
                     .right_min = s.right_min,
                     .texture_columns = s.texture_columns,
                     .texture_min = s.texture_min,
                     .d_min = f.d_min,
                     .d_max = f.d_max,
                     .texture_min8 = _mm256_set1_epi32(
                         static_cast<int>(std::min<std::uint32_t>(s.texture_min, 0x7FFFFFFF))),
                     .d_min8 = _mm256_set1_ps(f.d_min),
                     .d_max8 = _mm256_set1_ps(f.d_max)};
  const __m256i zero = _mm256_setzero_si256();
  FastFinishCounts n{zero, zero, zero, zero, zero, zero};
  int p = 0;
  for (; p + 8 <= t.w; p += 8) fast_finish8<kBits, kChecks>(t, p, out, n);
  add_fast_finish_counts(n, stats);
  for (; p < t.w; ++p) fast_finish1<kBits, kChecks>(t, p, out, stats);
}

template <int kBits, std::size_t... kChecks>
constexpr auto finish_row_table(std::index_sequence<kChecks...>) {
  return std::array{&finish_row_fast<kBits, static_cast<int>(kChecks)>...};
}
#endif

void scan_row(const RowScan& scan, bool portable);
void finish_row(const RowScan& s, int lr, bool subpixel, bool census, float d_min, float d_max,
                float* out, MatchStats& stats);

}  // namespace

void BlockMatcher::match_row(int y, float* out, MatchStats& stats) {
  const int w = width_, lanes = lanes_;
  const int num = options_.max_disparity - options_.min_disparity;
  const int d_top = options_.min_disparity + lanes - 1;  // disparity of lane 0
  RowScan scan{align64(column_sums_.data()), texture_columns_.data(), w, radius_, lanes, num, d_top,
               options_.uniqueness_ratio, texture_min_,
               volume_.data(), right_min_.data(), row_disp_.data(), row_state_.data()};
  if (options_.cost == MatchingCost::kSad && y > 0) {
    const int r = radius_, h = height_;
    const int y_new = std::min(y + r, h - 1), y_old = std::max(y - r - 1, 0);
    scan.left_new = left_.data() + static_cast<std::size_t>(y_new) * static_cast<std::size_t>(row_stride_l_);
    scan.left_old = left_.data() + static_cast<std::size_t>(y_old) * static_cast<std::size_t>(row_stride_l_);
    scan.right_new = right_.data() + static_cast<std::size_t>(y_new) * static_cast<std::size_t>(row_stride_r_);
    scan.right_old = right_.data() + static_cast<std::size_t>(y_old) * static_cast<std::size_t>(row_stride_r_);
  }
#if defined(__AVX2__)
  if (fast_row()) {
    const FastRow f{align64(volume_ring_.data()), row_fields_.data(), align64(near_masks_.data()),
                    lane_positions_.data() + kRingGuard, options_.lr_max_diff, options_.subpixel,
                    options_.cost == MatchingCost::kCensus, d_min_valid_, d_max_valid_};
    const bool slide = scan.left_new != nullptr;
    const auto run = [&]<int NV>() {
      if (!slide) scan_row_fast<NV, Slide::kNone>(scan, f);
      else scan_row_fast<NV, Slide::kSad>(scan, f);
      const int checks = (texture_min_ > 0 ? kFinishTexture : 0) |
                         (options_.uniqueness_ratio > 0 ? kFinishUnique : 0) |
                         (options_.lr_max_diff >= 0 ? kFinishLr : 0) |
                         (options_.subpixel ? kFinishSubpixel : 0);
      finish_row_table<NV == 2 ? 2 : 3>(std::make_index_sequence<16>{})[static_cast<std::size_t>(checks)](
          scan, f, out, stats);
    };
    if (lanes == 32) run.template operator()<2>();
    else run.template operator()<4>();
    return;
  }
#endif
  scan_row(scan, portable_);
  finish_row(scan, options_.lr_max_diff, options_.subpixel, options_.cost == MatchingCost::kCensus,
             d_min_valid_, d_max_valid_, out, stats);
}

namespace {

/// The row scan: AVX2 for whole registers of lanes, portable for the others or when asked.
void scan_row(const RowScan& scan, [[maybe_unused]] bool portable) {
#if defined(__AVX2__)
  switch (portable ? 0 : scan.lanes / 16) {
    case 2: scan_row_avx2<2>(scan); break;
    case 4: scan_row_avx2<4>(scan); break;
    case 6: scan_row_avx2<6>(scan); break;
    case 8: scan_row_avx2<8>(scan); break;
    case 10: scan_row_avx2<10>(scan); break;
    case 12: scan_row_avx2<12>(scan); break;
    case 14: scan_row_avx2<14>(scan); break;
    case 16: scan_row_avx2<16>(scan); break;
    default: scan_row_generic(scan); break;
  }
#else
  scan_row_generic(scan);
#endif
}

/// The row's disparities after scan_row: the left-right check, the subpixel fit and the depth
/// range for the candidates, the counts for all.
void finish_row(const RowScan& s, int lr, bool subpixel, bool census, float d_min, float d_max,
                float* out, MatchStats& stats) {
  const int w = s.width, lanes = s.lanes, num = s.num, d_top = s.d_top;
  const auto L = static_cast<std::size_t>(lanes);
  for (int x = 0; x < w; ++x) {
    out[x] = kNoDisparity;
    switch (s.state[static_cast<std::size_t>(x)]) {
      case kUnreachable: ++stats.unreachable; continue;
      case kLowTexture: ++stats.rejected_texture; continue;
      case kNotUnique: ++stats.rejected_uniqueness; continue;
      default: break;
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

void disparity_to_depth(const cv::Mat& disparity_px, const RectifiedStereo& rig,
                        cv::Mat& depth_m) {
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
