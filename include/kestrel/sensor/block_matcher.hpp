// Dense stereo by block matching on a rectified pair (thesis 2.5): SAD (or census) cost over a
// square window, winner-take-all over a disparity range, subpixel refinement, left-right
// consistency, uniqueness and texture checks, and a depth range. Written for one core: running
// column and box sums over uint16 costs, disparities contiguous in memory, no allocation per
// frame once the buffers are sized. Algorithm and figures: docs/stereo.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kestrel/geometry/pinhole_camera.hpp"

namespace kestrel::sensor {

/// Value of a disparity map where there is no disparity (Middlebury's PFM convention).
inline constexpr float kNoDisparity = std::numeric_limits<float>::infinity();
[[nodiscard]] inline bool has_disparity(float d) { return d < kNoDisparity && d == d; }

enum class MatchingCost {
  kSad,     ///< sum of absolute differences of the (prefiltered) intensities
  kCensus,  ///< Hamming distance of census signatures (robust to gain/bias changes)
};

enum class Prefilter {
  kNone,    ///< raw grey levels (SAD on intensities)
  kXSobel,  ///< horizontal Sobel response clamped to +-prefilter_cap (OpenCV StereoBM's)
};

/// "sad" / "census", "none" / "xsobel": the names in option files.
[[nodiscard]] std::string_view to_string(MatchingCost cost);
[[nodiscard]] std::string_view to_string(Prefilter prefilter);
/// The options-table hooks (io/option_fields.hpp); throw std::invalid_argument listing the
/// names.
void parse_option(std::string_view name, MatchingCost& cost);
void parse_option(std::string_view name, Prefilter& prefilter);

struct BlockMatcherOptions {
  /// Disparities searched: min_disparity <= d < max_disparity (OpenCV's numDisparities is
  /// max_disparity - min_disparity). Near the left border only the reachable d <= u are
  /// searched, so the leftmost columns still get a disparity.
  int min_disparity = 0;
  int max_disparity = 64;
  /// Side of the square matching window, odd, >= 3. With uint16 sums, block_size^2 times the
  /// largest per-pixel cost must stay below 65536 (SAD on raw intensities: <= 15; with the
  /// x-Sobel prefilter: <= 31; census 5x5: <= 51).
  int block_size = 9;
  MatchingCost cost = MatchingCost::kSad;
  /// Used by the SAD cost only (census is its own normalisation).
  Prefilter prefilter = Prefilter::kXSobel;
  int prefilter_cap = 31;  ///< 1..127: the prefiltered value lies in [0, 2 * cap]
  /// Census window side: 3, 5 or 7 (8, 24, 48 bits).
  int census_window = 5;
  /// Subpixel refinement: equiangular (V) fit for SAD, parabola for census.
  bool subpixel = true;
  /// Left-right check: the right view's best disparity at u - d must lie within this many
  /// pixels of d. Negative: off.
  int lr_max_diff = 1;
  /// Uniqueness: the best cost must beat every disparity further than 1 px from it by this
  /// margin in percent (OpenCV's uniquenessRatio). 0: off.
  int uniqueness_ratio = 10;
  /// Texture: the window's mean |horizontal gradient| of the left image, grey levels per
  /// pixel (central difference / 2), must reach this. 0: off.
  double texture_threshold = 0.25;
  /// Depth range (needs a rig): disparities whose depth B f / d lies outside are dropped.
  double min_depth_m = 0.0;
  double max_depth_m = std::numeric_limits<double>::infinity();

  template <typename V>
  void visit_fields(V&& v) {
    v("min_disparity", min_disparity);
    v("max_disparity", max_disparity);
    v("block_size", block_size);
    v("cost", cost);
    v("prefilter", prefilter);
    v("prefilter_cap", prefilter_cap);
    v("census_window", census_window);
    v("subpixel", subpixel);
    v("lr_max_diff", lr_max_diff);
    v("uniqueness_ratio", uniqueness_ratio);
    v("texture_threshold", texture_threshold);
    v("min_depth_m", min_depth_m);
    v("max_depth_m", max_depth_m);
  }

  /// Throws std::invalid_argument naming the bad field and its valid range.
  void validate() const;
  [[nodiscard]] std::string describe() const;
  /// The YAML fields, as load_yaml() reads them (max_depth_m may be .inf).
  [[nodiscard]] std::string to_yaml() const;
  /// YAML map with any of the field names (cost: sad|census, prefilter: none|xsobel);
  /// unknown keys are errors. Errors name the file and field.
  static BlockMatcherOptions load_yaml(const std::filesystem::path& path);
  /// The largest cost one pixel can contribute (for the uint16 bound).
  [[nodiscard]] int max_pixel_cost() const;
};

/// What happened to the pixels of one match: its health.
struct MatchStats {
  std::size_t pixels = 0;
  std::size_t valid = 0;
  std::size_t rejected_texture = 0;
  std::size_t rejected_uniqueness = 0;
  std::size_t rejected_lr = 0;
  std::size_t rejected_depth = 0;
  std::size_t unreachable = 0;  ///< u < min_disparity: nothing to search
  [[nodiscard]] double fill_rate() const {
    return pixels == 0 ? 0.0 : static_cast<double>(valid) / static_cast<double>(pixels);
  }
  [[nodiscard]] std::string describe() const;
};

class BlockMatcher {
 public:
  /// Throws std::invalid_argument for invalid options, or when a depth range is set without
  /// a rig.
  explicit BlockMatcher(BlockMatcherOptions options = {},
                        std::optional<RectifiedStereo> rig = std::nullopt);

  [[nodiscard]] const BlockMatcherOptions& options() const { return options_; }
  [[nodiscard]] const std::optional<RectifiedStereo>& rig() const { return rig_; }

  /// Disparity of the LEFT view (CV_32F, d = uL - uR, kNoDisparity where none) of a rectified
  /// pair: 8-bit grey (fast path), 8-bit BGR or float grey in [0, 255]. Throws InputError for
  /// empty images, images of different sizes or unsupported types. `disparity` is reused.
  MatchStats match(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity);
  [[nodiscard]] cv::Mat match(const cv::Mat& left, const cv::Mat& right);

  /// Runs the scalar reference row scan instead of the SIMD kernels, for tests and benchmarks
  /// that compare them: the maps and stats are the same by design. Off by default.
  void set_portable(bool portable) { portable_ = portable; }
  [[nodiscard]] bool portable() const { return portable_; }

 private:
  void prepare(int width, int height);
  void select_simd_target();
  void preprocess(const cv::Mat& left, const cv::Mat& right);
  void init_column_sums();
  void advance_column_sums(int y);
  void match_row(int y, float* out, MatchStats& stats);

  BlockMatcherOptions options_;
  std::optional<RectifiedStereo> rig_;
  int width_ = 0, height_ = 0;
  int radius_ = 0;
  int lanes_ = 0;     // disparity lanes, a multiple of 32 (>= max - min)
  int pad_left_ = 0;  // right-row padding on the left: lanes - 1 + min_disparity + radius
  int row_stride_l_ = 0, row_stride_r_ = 0;
  float d_min_valid_ = 0.0F, d_max_valid_ = kNoDisparity;  // from the depth range
  std::uint32_t texture_min_ = 0;  // least window sum of |central difference|; 0: no test
  bool fast_ = false;              // the options suit the tagged-cost fast row (32 or 64 lanes)
  bool portable_ = false;          // set_portable: the scalar reference even with SIMD
  int vector_lanes_ = -1;          // uint16 lanes of the SIMD target in use; < 8: none (scalar)
  cv::Mat gray_l_, gray_r_;        // 8-bit grey inputs (converted)
  std::vector<std::uint8_t> left_, right_;          // padded, prefiltered rows
  std::vector<std::uint64_t> census_l_, census_r_;  // padded census signatures
  std::vector<std::uint8_t> cost_ring_;             // census: per-pixel cost rows
  std::vector<std::uint16_t> column_sums_;          // (W + 2r) x lanes
  std::vector<std::uint32_t> texture_columns_;      // W + 2r
  std::vector<std::uint8_t> gradient_;              // H x (W + 2r): texture input
  std::vector<std::uint16_t> volume_;               // W x lanes: box costs of a row
  std::vector<std::uint16_t> right_min_;            // W + lanes: right view's best
  std::vector<std::int32_t> row_disp_;              // winning lane per u, -1 none
  std::vector<std::uint8_t> row_state_;
  // Fast row (SIMD, 32 or 64 lanes): its column sums are scaled by column_scale() and stored
  // in its lane order (storage_order, which depends on the vector width); box costs of the
  // last pixels, the per-pixel fields the scan leaves for the finish, the winner's neighbour
  // masks and the slot position of each lane.
  [[nodiscard]] bool simd() const;          // SIMD kernels: a target with vectors, not portable
  [[nodiscard]] bool fast_row() const;      // fast_, simd(), width within its limit
  [[nodiscard]] int column_scale() const;   // 2^tag bits on the fast row, else 1
  [[nodiscard]] int storage_order() const;  // fast_lane_position's vector_lanes (0: lane order)
  std::vector<std::uint16_t> volume_ring_, row_fields_, near_masks_;
  std::vector<std::int16_t> lane_positions_;
};

/// The SIMD target the block matcher's row kernels run on (Google Highway's name: "AVX2",
/// "AVX3", "SSE4", "NEON", "EMU128", ...): the best one the CPU has, or the one a test forces
/// with hwy::SetSupportedTargetsForTest.
[[nodiscard]] const char* block_matching_simd_target();
/// Every target the kernels were compiled for that this CPU supports, best first (Highway's
/// target bits), for tests that run the matcher on each.
[[nodiscard]] std::vector<std::int64_t> block_matching_simd_targets();

/// Disparity to depth Z = B f / d (thesis eq. 2.9), CV_32F metres, 0 where no disparity.
void disparity_to_depth(const cv::Mat& disparity_px, const RectifiedStereo& rig, cv::Mat& depth_m);

}  // namespace kestrel::sensor
