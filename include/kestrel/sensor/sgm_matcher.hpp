// Dense stereo by semi-global matching (Hirschmueller, "Stereo processing by semiglobal matching
// and mutual information", PAMI 2008) on a rectified pair: census matching costs (Zabih &
// Woodfill 1994; centre-symmetric by default, as in Spangenberg et al., IV 2014), path costs
// summed over 4 or 8 directions, winner-take-all, subpixel parabola, left-right check and
// optional speckle removal. The quality mode beside the fast BlockMatcher. Written for one core:
// uint16 costs, SIMD over the disparities of a pixel (Google Highway, runtime dispatch), two
// passes over the image (top-down, then bottom-up) so that only one summed-cost volume is kept.
// Algorithm and figures: docs/stereo.md.
#pragma once

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/sensor/block_matcher.hpp"

namespace kestrel::sensor {

enum class CensusPattern {
  kFull,             ///< every window pixel against the centre (window area - 1 bits <= 32)
  kCenterSymmetric,  ///< each pixel against its mirror through the centre ((area - 1) / 2 bits)
};

/// "full" / "center_symmetric": the names in option files.
[[nodiscard]] std::string_view to_string(CensusPattern pattern);
/// The options-table hook (io/option_fields.hpp); throws std::invalid_argument listing the names.
void parse_option(std::string_view name, CensusPattern& pattern);

struct SgmOptions {
  /// Disparities searched: min_disparity <= d < max_disparity. Near the left border, where the
  /// right pixel of d lies outside the image, the cost of d is unknown: it gets a neutral cost
  /// (half the census bits) and the paths carry disparities in from the inside.
  int min_disparity = 0;
  int max_disparity = 64;
  /// Census window (odd sides). The default 9x7 centre-symmetric census (31 bits) is the cost
  /// of Spangenberg et al. (IV 2014): a wide support at a 32-bit signature.
  int census_width = 9;
  int census_height = 7;
  CensusPattern census = CensusPattern::kCenterSymmetric;
  /// Penalties of eq. 11 (in census bits): P1 for a 1 px change of disparity between
  /// neighbours along a path, P2 for a larger jump. P2 is adapted to the intensity step
  /// between the neighbours (eq. 16): P2(dI) = max(P1, P2 * g / (g + |dI|)), g =
  /// p2_gradient grey levels (0: a constant P2), so that disparity edges may follow image edges.
  /// The defaults were chosen once for all scenes (docs/stereo.md): P1 about a third of the
  /// bits (a one-pixel step must cost less than a clear mismatch), P2 several mismatches, and
  /// g = 8 grey levels (P2 halves at a step of 8, about the noise of an 8-bit camera tripled).
  int p1 = 12;
  int p2 = 150;
  int p2_gradient = 8;
  /// Directions summed: 8 (horizontal, vertical, diagonals) or 4 (horizontal, vertical).
  int paths = 8;
  /// Parabola through the summed costs at d - 1, d, d + 1.
  bool subpixel = true;
  /// Left-right check: the right pixel u - d must have its least summed cost within this many
  /// pixels of d. Negative: off, the default: the median already removes isolated outliers,
  /// and what the check removes beyond them (occlusions, thin structures) costs more correct
  /// pixels than wrong ones on the Middlebury scenes (docs/stereo.md); consumers that prefer
  /// holes to guesses in occlusions set 1.
  int lr_max_diff = -1;
  /// 3x3 median of the disparities before the left-right check removes any (Hirschmueller
  /// 2008, 4.1): isolated outliers go, edges stay.
  bool median = true;
  /// Speckle removal: connected regions (4-neighbours, disparities within speckle_max_diff px)
  /// of at most speckle_size pixels are removed. 0: off.
  int speckle_size = 0;
  double speckle_max_diff = 1.0;

  template <typename V>
  void visit_fields(V&& v) {
    v("min_disparity", min_disparity);
    v("max_disparity", max_disparity);
    v("census_width", census_width);
    v("census_height", census_height);
    v("census", census);
    v("p1", p1);
    v("p2", p2);
    v("p2_gradient", p2_gradient);
    v("paths", paths);
    v("subpixel", subpixel);
    v("lr_max_diff", lr_max_diff);
    v("median", median);
    v("speckle_size", speckle_size);
    v("speckle_max_diff", speckle_max_diff);
  }

  /// Throws std::invalid_argument naming the bad field and its valid range.
  void validate() const;
  [[nodiscard]] std::string describe() const;
  [[nodiscard]] std::string to_yaml() const;
  /// YAML map with any of the field names; unknown keys are errors naming the file and field.
  static SgmOptions load_yaml(const std::filesystem::path& path);
  /// Census bits: the largest matching cost.
  [[nodiscard]] int census_bits() const;
};

namespace detail {
/// uint16 storage whose data() starts on a 64-byte boundary, so that whole-vector loads of
/// lanes at multiples of 32 stay within one cache line.
class AlignedU16 {
 public:
  void assign(std::size_t n, std::uint16_t value) {
    storage_.assign(n + 32, value);
    const auto address = reinterpret_cast<std::uintptr_t>(storage_.data());
    offset_ = ((64 - address % 64) % 64) / sizeof(std::uint16_t);
    size_ = n;
  }
  void fill(std::uint16_t value) { std::fill(storage_.begin(), storage_.end(), value); }
  [[nodiscard]] std::uint16_t* data() { return storage_.data() + offset_; }
  [[nodiscard]] const std::uint16_t* data() const { return storage_.data() + offset_; }
  [[nodiscard]] std::uint16_t operator[](std::size_t i) const { return data()[i]; }
  [[nodiscard]] std::size_t size() const { return size_; }

 private:
  std::vector<std::uint16_t> storage_;
  std::size_t offset_ = 0, size_ = 0;
};
}  // namespace detail

class SgmMatcher {
 public:
  /// Throws std::invalid_argument for invalid options.
  explicit SgmMatcher(SgmOptions options = {});

  [[nodiscard]] const SgmOptions& options() const { return options_; }

  /// Disparity of the LEFT view (CV_32F, d = uL - uR, kNoDisparity where none) of a rectified
  /// pair: 8-bit grey, 8-bit BGR or float grey in [0, 255]. Throws InputError for empty images,
  /// images of different sizes or unsupported types. `disparity` is reused.
  MatchStats match(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity);
  [[nodiscard]] cv::Mat match(const cv::Mat& left, const cv::Mat& right);

  /// Runs the scalar reference kernels instead of the SIMD ones (tests, benchmarks): the maps
  /// are the same bit for bit.
  void set_reference(bool reference) { reference_ = reference; }
  [[nodiscard]] bool reference() const { return reference_; }
  /// Whether the SIMD kernels may keep the path costs in 8 bits (default: yes). They do so
  /// only where that is exact, census bits + p2 <= 254 (the defaults: 31 + 150), and the maps
  /// are the same bit for bit either way; false forces the 16-bit recursion (tests, benchmarks).
  void allow_8bit_paths(bool allow) { allow_8bit_ = allow; }
  /// True iff match() runs the 8-bit path recursion: allowed, the SIMD kernels, and options
  /// whose path costs fit.
  [[nodiscard]] bool runs_8bit_paths() const;
  /// Pixels the last match's speckle removal took out (MatchStats has no field for them; they
  /// are not in its `valid`).
  [[nodiscard]] std::size_t speckles_removed() const { return speckles_removed_; }
  /// The SIMD target the kernels run on now, and every one compiled in that this CPU runs
  /// (Highway target bits, best first; hwy::SetSupportedTargetsForTest selects one).
  [[nodiscard]] static const char* simd_target();
  [[nodiscard]] static std::vector<std::int64_t> simd_targets();

 private:
  void prepare(int width, int height);
  void census(const cv::Mat& gray, std::vector<std::uint16_t>& low,
              std::vector<std::uint16_t>& high);
  void cost_row(int y);
  void pass(int dir, cv::Mat& disparity);
  void decide_row(int y, float* out);
  void finish(cv::Mat& disparity, MatchStats& stats);
  [[nodiscard]] bool left_right_consistent(int x, int k) const;
  void remove_speckles(cv::Mat& disparity, MatchStats& stats);

  SgmOptions options_;
  bool reference_ = false;
  bool allow_8bit_ = true;
  std::size_t speckles_removed_ = 0;
  int width_ = 0, height_ = 0;
  int range_ = 0;                                  // max - min disparity
  int lanes_ = 0;                                  // range rounded up to the widest vector
  cv::Mat left_, gray_l_, gray_r_, padded_;        // left_: the 8-bit left view of this match
  std::vector<std::int32_t> offset_a_, offset_b_;  // census pairs
  std::vector<std::uint16_t> census_l_lo_, census_l_hi_;  // H x (W + 32)
  std::vector<std::uint16_t> census_r_lo_, census_r_hi_;
  std::vector<std::uint16_t> rev_lo_, rev_hi_;  // one right row, reversed
  std::vector<std::uint16_t> pad_mask_, p2_lut_, p2_row_;
  detail::AlignedU16 cost_;    // one row: W x lanes
  detail::AlignedU16 volume_;  // H x W x lanes: the top-down pass's sums
  detail::AlignedU16 total_;   // one row: all paths summed
  detail::AlignedU16 rows_;    // path rows: 2 x 3 x (W + 2) slots
  std::vector<std::uint16_t> row_min_;
  detail::AlignedU16 horizontal_;
  std::vector<std::int32_t> best_;
  std::vector<std::uint16_t> best_cost_, right_min_rev_;
  std::vector<std::uint8_t> rejected_;  // H x W: the left-right check failed
  cv::Mat median_, speckle_fixed_, speckle_buffer_;
};

}  // namespace kestrel::sensor
