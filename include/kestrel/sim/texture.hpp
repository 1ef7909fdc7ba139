// Surface textures in metric coordinates: an image tiled over a surface (texel size in metres),
// mip-mapped so that distant surfaces are prefiltered, plus the procedural textures of the
// synthetic scenes (value noise, checkerboard, blobs, nearly textureless walls).
#pragma once

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <vector>

namespace kestrel::sim {

/// Linear colour in [0, 1] per channel, in OpenCV's channel order (blue, green, red).
using ColorBgr = cv::Vec3f;

/// A colour image repeated over the plane: texel (i, j) covers the square
/// [i, i+1) x [j, j+1) * texel size, so a texture is periodic with period width * texel size.
/// Immutable once built; scenes share textures through shared_ptr<const Texture>.
class Texture {
 public:
  /// From an image: CV_8U (0..255), CV_16U (0..65535) or CV_32F (0..1), 1 or 3 channels
  /// (3 = BGR as OpenCV loads it). Each texel covers texel_size_m x texel_size_m.
  /// Throws std::invalid_argument for an empty image, another type or a size <= 0.
  static Texture from_image(const cv::Mat& image, double texel_size_m);
  /// Loads an image file (any format OpenCV reads); throws InputError naming the file.
  static Texture load(const std::filesystem::path& file, double texel_size_m);
  /// A single colour (a 1x1 image).
  static Texture constant(const ColorBgr& color);

  [[nodiscard]] int width() const { return levels_.front().cols; }
  [[nodiscard]] int height() const { return levels_.front().rows; }
  [[nodiscard]] double texel_size_m() const { return texel_size_m_; }
  /// Number of mip levels (level 0 is the image; each next one is half the size, to 1x1).
  [[nodiscard]] int levels() const { return static_cast<int>(levels_.size()); }
  /// Mip level `l`, CV_32FC3.
  [[nodiscard]] const cv::Mat& level(int l) const { return levels_[static_cast<std::size_t>(l)]; }

  /// Bilinear lookup at surface coordinates (s, t) in metres on level 0 (no prefiltering):
  /// the value at a texel centre is that texel's colour exactly.
  [[nodiscard]] ColorBgr sample(double s_m, double t_m) const;
  /// Trilinear (mip-mapped) lookup for a pixel footprint of `footprint_m` metres on the
  /// surface: bilinear on level 0 while footprint <= texel size, blended between the two
  /// nearest levels beyond (the OpenGL LINEAR_MIPMAP_LINEAR filter).
  [[nodiscard]] ColorBgr sample(double s_m, double t_m, double footprint_m) const;
  /// The same with the level of detail given directly: lod = log2(footprint / texel size).
  [[nodiscard]] ColorBgr sample_lod(double s_m, double t_m, float lod) const;

  /// Mean colour of the whole texture (the top mip level).
  [[nodiscard]] ColorBgr mean() const;

 private:
  Texture() = default;
  void build_mipmaps();
  [[nodiscard]] ColorBgr sample_level(int l, double s_m, double t_m) const;

  struct LevelInfo {
    const float* data = nullptr;  // the level's texels, a spare row behind them
    std::size_t row_floats = 3;   // floats per row
    int width = 1, height = 1;
    double texels_per_m_s = 1.0, texels_per_m_t = 1.0;
    bool power_of_two = false;  // wrap by masking
  };
  std::vector<cv::Mat> levels_;  // CV_32FC3, continuous, each with a spare row in its buffer
  std::vector<LevelInfo> info_;
  double texel_size_m_ = 0.01;
  double period_s_m_ = 0.01;  // width * texel size
  double period_t_m_ = 0.01;  // height * texel size
};

/// Multi-octave value noise (smooth random lattice values, quintic interpolation, each octave
/// twice the frequency and `persistence` times the amplitude of the previous), periodic over
/// the tile, normalised to mean 0.5 and standard deviation 0.2 (clamped to [0, 1]), then
/// mapped linearly from `dark` (0) to `bright` (1). Contrast is therefore set by the colours.
struct ValueNoiseOptions {
  int size_px = 512;            ///< tile size in texels (square)
  double texel_size_m = 0.008;  ///< metres per texel: a 512 tile spans 4.1 m
  int base_cells = 8;           ///< lattice cells per tile at the coarsest octave
  int octaves = 5;
  double persistence = 0.55;
  ColorBgr dark{0.2F, 0.2F, 0.2F};
  ColorBgr bright{0.8F, 0.8F, 0.8F};
};
Texture make_value_noise_texture(const ValueNoiseOptions& options, std::uint64_t seed);

/// A nearly textureless surface: value noise between base*(1 - contrast) and
/// base*(1 + contrast); contrast 0.01 is a +-1 % (about +-2 grey levels) painted wall.
Texture make_low_contrast_texture(const ColorBgr& base, double contrast, std::uint64_t seed,
                                  double texel_size_m = 0.02);

/// Checkerboard of `square_m` squares, `texels_per_square` texels each (edges stay sharp to
/// that resolution); the tile holds 2x2 squares. Starts with colour `a` at (0, 0).
Texture make_checkerboard_texture(double square_m, const ColorBgr& a, const ColorBgr& b,
                                  int texels_per_square = 8);

/// Random soft-edged discs of random colours on a base colour ("posters, marks, patches").
struct BlobTextureOptions {
  int size_px = 512;
  double texel_size_m = 0.008;
  int count = 150;
  double min_radius_px = 4.0;
  double max_radius_px = 30.0;
  ColorBgr base{0.75F, 0.78F, 0.8F};
  float saturation = 0.7F;  ///< 0 = grey blobs, 1 = fully random colours
  /// Overall noise under the blobs (value noise amplitude, 0 = flat base).
  float base_noise = 0.05F;
};
Texture make_blob_texture(const BlobTextureOptions& options, std::uint64_t seed);

}  // namespace kestrel::sim
