// Texture storage, mip-mapped lookup, and the procedural textures of the synthetic scenes.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/core/random.hpp"
#include "kestrel/sim/texture.hpp"

namespace kestrel::sim {

namespace {

/// splitmix64: decorrelates nearby seeds (seed, seed + 1, ...) before seeding a generator.
std::uint64_t mix_seed(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

double quintic(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

/// Periodic multi-octave value noise (CV_32F), normalised to mean 0.5, sigma 0.2, clamped.
cv::Mat value_noise(int size, int base_cells, int octaves, double persistence, std::uint64_t seed) {
  cv::Mat acc(size, size, CV_32F, cv::Scalar(0));
  double amplitude = 1.0;
  std::vector<float> lattice;
  for (int o = 0; o < octaves; ++o, amplitude *= persistence) {
    const int cells = base_cells << o;
    if (cells > size) break;
    std::mt19937_64 rng(mix_seed(seed * 131 + static_cast<std::uint64_t>(o)));
    lattice.resize(static_cast<std::size_t>(cells) * static_cast<std::size_t>(cells));
    for (float& v : lattice) v = static_cast<float>(uniform01(rng));
    const double scale = static_cast<double>(cells) / size;
    for (int y = 0; y < size; ++y) {
      const double fy = (y + 0.5) * scale;
      const int iy0 = static_cast<int>(fy);
      const int iy1 = (iy0 + 1) % cells;
      const auto ty = static_cast<float>(quintic(fy - iy0));
      const float* row0 = &lattice[static_cast<std::size_t>(iy0 % cells) * cells];
      const float* row1 = &lattice[static_cast<std::size_t>(iy1) * cells];
      auto* out = acc.ptr<float>(y);
      for (int x = 0; x < size; ++x) {
        const double fx = (x + 0.5) * scale;
        const int ix0 = static_cast<int>(fx) % cells;
        const int ix1 = (ix0 + 1) % cells;
        const auto tx = static_cast<float>(quintic(fx - static_cast<int>(fx)));
        const float top = row0[ix0] + tx * (row0[ix1] - row0[ix0]);
        const float bottom = row1[ix0] + tx * (row1[ix1] - row1[ix0]);
        out[x] += static_cast<float>(amplitude) * (top + ty * (bottom - top));
      }
    }
  }
  cv::Scalar mean, stddev;
  cv::meanStdDev(acc, mean, stddev);
  const double gain = stddev[0] > 0.0 ? 0.2 / stddev[0] : 0.0;
  acc.convertTo(acc, CV_32F, gain, 0.5 - gain * mean[0]);
  cv::min(cv::max(acc, 0.0), 1.0, acc);
  return acc;
}

cv::Mat blend_colors(const cv::Mat& t01, const ColorBgr& a, const ColorBgr& b) {
  cv::Mat out(t01.size(), CV_32FC3);
  for (int y = 0; y < t01.rows; ++y) {
    const auto* in = t01.ptr<float>(y);
    auto* px = out.ptr<cv::Vec3f>(y);
    for (int x = 0; x < t01.cols; ++x) px[x] = a + in[x] * (b - a);
  }
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Texture

Texture Texture::from_image(const cv::Mat& image, double texel_size_m) {
  if (image.empty()) throw std::invalid_argument("Texture: empty image");
  if (!(texel_size_m > 0.0) || !std::isfinite(texel_size_m)) {
    throw std::invalid_argument("Texture: texel size must be positive");
  }
  if (image.channels() != 1 && image.channels() != 3) {
    throw std::invalid_argument("Texture: image must have 1 or 3 channels");
  }
  double scale = 1.0;
  switch (image.depth()) {
    case CV_8U:
      scale = 1.0 / 255.0;
      break;
    case CV_16U:
      scale = 1.0 / 65535.0;
      break;
    case CV_32F:
      scale = 1.0;
      break;
    default:
      throw std::invalid_argument("Texture: image must be 8-bit, 16-bit or float");
  }
  cv::Mat f;
  image.convertTo(f, CV_32F, scale);
  if (f.channels() == 1) cv::cvtColor(f, f, cv::COLOR_GRAY2BGR);
  Texture tex;
  tex.levels_.push_back(f);
  tex.texel_size_m_ = texel_size_m;
  tex.period_s_m_ = texel_size_m * f.cols;
  tex.period_t_m_ = texel_size_m * f.rows;
  tex.build_mipmaps();
  return tex;
}

Texture Texture::load(const std::filesystem::path& file, double texel_size_m) {
  if (!std::filesystem::exists(file)) {
    throw InputError(file.string() + ": texture image does not exist");
  }
  const cv::Mat image = cv::imread(file.string(), cv::IMREAD_COLOR);
  if (image.empty()) throw InputError(file.string() + ": cannot decode the texture image");
  return from_image(image, texel_size_m);
}

Texture Texture::constant(const ColorBgr& color) {
  return from_image(cv::Mat(1, 1, CV_32FC3, cv::Scalar(color[0], color[1], color[2])), 1.0);
}

namespace {
/// A continuous copy of a CV_32FC3 level with one spare (zero) row behind it, in the same
/// buffer: the lookup loads each texel's three floats as four, so the last texel's load reads
/// one float past the image.
cv::Mat with_spare_row(const cv::Mat& level) {
  cv::Mat buffer(level.rows + 1, level.cols, CV_32FC3, cv::Scalar::all(0));
  cv::Mat image = buffer.rowRange(0, level.rows);
  level.copyTo(image);
  return image;
}
}  // namespace

void Texture::build_mipmaps() {
  levels_.front() = with_spare_row(levels_.front());
  while (levels_.back().cols > 1 || levels_.back().rows > 1) {
    const cv::Mat& prev = levels_.back();
    cv::Mat next;
    cv::resize(prev, next, cv::Size((prev.cols + 1) / 2, (prev.rows + 1) / 2), 0, 0,
               cv::INTER_AREA);
    levels_.push_back(with_spare_row(next));
  }
  info_.clear();
  for (const cv::Mat& l : levels_) {
    const auto pow2 = [](int n) { return (n & (n - 1)) == 0; };
    // The cv::Mat headers share (and keep alive) the buffers these pointers point into.
    info_.push_back({l.ptr<float>(0), 3 * static_cast<std::size_t>(l.cols), l.cols, l.rows,
                     l.cols / period_s_m_, l.rows / period_t_m_, pow2(l.cols) && pow2(l.rows)});
  }
}

namespace {

/// Four floats in one register (GCC and Clang vector extension): a texel's blue, green, red
/// and one float of the next texel, which the arithmetic carries along and the result drops.
using Lanes = float __attribute__((vector_size(16)));

inline Lanes load_texel(const float* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

/// A texel coordinate's column (or row) wrapped into [0, n), the next one (wrapped) and the
/// fraction between them.
struct Tap {
  int i0, i1;
  float frac;
};

inline Tap wrap_texel(double x, int n, bool power_of_two) {
  if (!(std::abs(x) < 1e9)) {  // far away (an infinite plane's horizon), or not a number
    x = std::isfinite(x) ? std::fmod(x, n) : 0.0;
  }
  // Floor by truncation (|x| < 1e9 fits an int): cheaper than std::floor, which baseline
  // x86-64 has no instruction for; the same value.
  int i = static_cast<int>(x);
  if (static_cast<double>(i) > x) --i;
  const auto frac = static_cast<float>(x - static_cast<double>(i));
  if (power_of_two) {
    i &= n - 1;
  } else {
    i %= n;
    if (i < 0) i += n;
  }
  return {i, i + 1 == n ? 0 : i + 1, frac};
}

/// Bilinear lookup on one level (a Texture::LevelInfo, whose type is private to the class).
/// The arithmetic is that of three scalar channels (the same operations in the same order, so
/// the same colours), done on the three at once.
template <typename Level>
inline Lanes bilinear(const Level& level, double s_m, double t_m) {
  // Texel centres sit at (i + 0.5) * texel; the texture repeats (wraps) in both directions.
  const Tap x = wrap_texel(s_m * level.texels_per_m_s - 0.5, level.width, level.power_of_two);
  const Tap y = wrap_texel(t_m * level.texels_per_m_t - 0.5, level.height, level.power_of_two);
  const float* r0 = level.data + static_cast<std::size_t>(y.i0) * level.row_floats;
  const float* r1 = level.data + static_cast<std::size_t>(y.i1) * level.row_floats;
  const auto c0 = 3 * static_cast<std::size_t>(x.i0);
  const auto c1 = 3 * static_cast<std::size_t>(x.i1);
  const Lanes a = load_texel(r0 + c0), b = load_texel(r0 + c1);
  const Lanes c = load_texel(r1 + c0), d = load_texel(r1 + c1);
  const Lanes top = a + x.frac * (b - a);
  const Lanes bottom = c + x.frac * (d - c);
  return top + y.frac * (bottom - top);
}

inline ColorBgr bgr(const Lanes& v) { return {v[0], v[1], v[2]}; }

}  // namespace

ColorBgr Texture::sample_level(int l, double s_m, double t_m) const {
  return bgr(bilinear(info_[static_cast<std::size_t>(l)], s_m, t_m));
}

ColorBgr Texture::sample(double s_m, double t_m) const { return sample_level(0, s_m, t_m); }

ColorBgr Texture::sample(double s_m, double t_m, double footprint_m) const {
  if (!(footprint_m > texel_size_m_)) return sample_level(0, s_m, t_m);
  return sample_lod(s_m, t_m, static_cast<float>(std::log2(footprint_m / texel_size_m_)));
}

// Both levels' lookups inline, blended in the four lanes: this is the renderer's lookup.
ColorBgr Texture::sample_lod(double s_m, double t_m, float lod) const {
  if (!(lod > 0.0F)) return bgr(bilinear(info_.front(), s_m, t_m));
  const int top = levels() - 1;
  if (lod >= static_cast<float>(top)) return levels_.back().at<cv::Vec3f>(0, 0);
  const int l = static_cast<int>(lod);
  const float f = lod - static_cast<float>(l);
  const Lanes fine = bilinear(info_[static_cast<std::size_t>(l)], s_m, t_m);
  if (f == 0.0F) return bgr(fine);
  const Lanes coarse = bilinear(info_[static_cast<std::size_t>(l) + 1], s_m, t_m);
  return bgr(fine + f * (coarse - fine));
}

ColorBgr Texture::mean() const {
  const cv::Scalar m = cv::mean(levels_.front());
  return {static_cast<float>(m[0]), static_cast<float>(m[1]), static_cast<float>(m[2])};
}

// ---------------------------------------------------------------------------------------------
// Procedural textures

Texture make_value_noise_texture(const ValueNoiseOptions& o, std::uint64_t seed) {
  if (o.size_px < 2 || o.base_cells < 1 || o.octaves < 1) {
    throw std::invalid_argument("make_value_noise_texture: size >= 2, cells >= 1, octaves >= 1");
  }
  const cv::Mat n = value_noise(o.size_px, o.base_cells, o.octaves, o.persistence, seed);
  return Texture::from_image(blend_colors(n, o.dark, o.bright), o.texel_size_m);
}

Texture make_low_contrast_texture(const ColorBgr& base, double contrast, std::uint64_t seed,
                                  double texel_size_m) {
  ValueNoiseOptions o;
  o.size_px = 256;
  o.texel_size_m = texel_size_m;
  o.base_cells = 4;
  o.octaves = 5;
  o.persistence = 0.6;
  o.dark = base * static_cast<float>(1.0 - contrast);
  o.bright = base * static_cast<float>(1.0 + contrast);
  return make_value_noise_texture(o, seed);
}

Texture make_checkerboard_texture(double square_m, const ColorBgr& a, const ColorBgr& b,
                                  int texels_per_square) {
  if (!(square_m > 0.0) || texels_per_square < 1) {
    throw std::invalid_argument("make_checkerboard_texture: square and texels must be positive");
  }
  const int n = texels_per_square;
  cv::Mat img(2 * n, 2 * n, CV_32FC3);
  for (int y = 0; y < 2 * n; ++y) {
    for (int x = 0; x < 2 * n; ++x) {
      img.at<cv::Vec3f>(y, x) = ((x / n + y / n) % 2 == 0) ? a : b;
    }
  }
  return Texture::from_image(img, square_m / n);
}

Texture make_blob_texture(const BlobTextureOptions& o, std::uint64_t seed) {
  if (o.size_px < 2 || !(o.min_radius_px > 0.0) || o.max_radius_px < o.min_radius_px) {
    throw std::invalid_argument("make_blob_texture: invalid size or radii");
  }
  const int size = o.size_px;
  cv::Mat img;
  if (o.base_noise > 0.0F) {
    const cv::Mat n = value_noise(size, 8, 5, 0.55, seed ^ 0x5EEDULL);
    img = blend_colors(n, o.base * (1.0F - o.base_noise), o.base * (1.0F + o.base_noise));
  } else {
    img = cv::Mat(size, size, CV_32FC3, cv::Scalar(o.base[0], o.base[1], o.base[2]));
  }
  std::mt19937_64 rng(mix_seed(seed));
  for (int i = 0; i < o.count; ++i) {
    const double cx = uniform01(rng) * size;
    const double cy = uniform01(rng) * size;
    // Log-uniform radii: many small marks, a few large patches.
    const double r = o.min_radius_px * std::pow(o.max_radius_px / o.min_radius_px, uniform01(rng));
    const auto grey = static_cast<float>(0.1 + 0.8 * uniform01(rng));
    ColorBgr random_color;
    for (int c = 0; c < 3; ++c) random_color[c] = static_cast<float>(uniform01(rng));
    const ColorBgr color =
        (1.0F - o.saturation) * ColorBgr(grey, grey, grey) + o.saturation * random_color;
    const int reach = static_cast<int>(std::ceil(r + 1.5));
    for (int dy = -reach; dy <= reach; ++dy) {
      const int y = static_cast<int>(std::floor(cy)) + dy;
      const int yw = ((y % size) + size) % size;
      auto* row = img.ptr<cv::Vec3f>(yw);
      for (int dx = -reach; dx <= reach; ++dx) {
        const int x = static_cast<int>(std::floor(cx)) + dx;
        const double d = std::hypot(x + 0.5 - cx, y + 0.5 - cy);
        // Soft edge over about 1.5 texels so that the disc's boundary is not aliased.
        const double alpha = std::clamp((r + 0.75 - d) / 1.5, 0.0, 1.0);
        if (alpha <= 0.0) continue;
        cv::Vec3f& px = row[((x % size) + size) % size];
        px += static_cast<float>(alpha) * (color - px);
      }
    }
  }
  return Texture::from_image(img, o.texel_size_m);
}

}  // namespace kestrel::sim
