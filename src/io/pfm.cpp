// PFM reading and writing (Middlebury float disparity maps).
#include "kestrel/io/pfm.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "kestrel/core/error.hpp"

namespace kestrel::io {
namespace fs = std::filesystem;

namespace {

std::string next_token(std::istream& in, const fs::path& path, const char* what) {
  std::string token;
  // Header tokens are separated by whitespace; '#' comments are not part of the format.
  if (!(in >> token)) throw InputError(path.string() + ": PFM header ends before the " + what);
  return token;
}

}  // namespace

cv::Mat read_pfm(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string() + ": cannot open");
  const std::string magic = next_token(in, path, "magic number");
  int channels = 0;
  if (magic == "Pf")
    channels = 1;
  else if (magic == "PF")
    channels = 3;
  else
    throw InputError(path.string() + ": not a PFM file (magic '" + magic + "', expected Pf or PF)");
  int width = 0, height = 0;
  double scale = 0.0;
  try {
    width = std::stoi(next_token(in, path, "width"));
    height = std::stoi(next_token(in, path, "height"));
    scale = std::stod(next_token(in, path, "scale"));
  } catch (const std::logic_error&) {
    throw InputError(path.string() + ": PFM header: width, height and scale must be numbers");
  }
  if (width <= 0 || height <= 0 || width > (1 << 16) || height > (1 << 16)) {
    throw InputError(path.string() + ": PFM header: bad size " + std::to_string(width) + "x" +
                     std::to_string(height));
  }
  if (scale == 0.0 || !std::isfinite(scale)) {
    throw InputError(path.string() + ": PFM header: the scale must be a non-zero number");
  }
  in.get();  // the single whitespace character that ends the header
  const bool file_little = scale < 0.0;
  const bool swap = file_little != (std::endian::native == std::endian::little);
  const std::size_t row_bytes =
      static_cast<std::size_t>(width) * static_cast<std::size_t>(channels) * 4U;
  // The data must be in the file before the image is allocated: a 20-byte header claiming
  // 65536x65536 colour pixels asked for 48 GiB (found by fuzz/pfm.cpp).
  const std::streamoff data_start = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff file_end = in.tellg();
  in.seekg(data_start);
  if (data_start < 0 || file_end < data_start ||
      static_cast<std::size_t>(file_end - data_start) / row_bytes <
          static_cast<std::size_t>(height)) {
    throw InputError(path.string() + ": PFM data ends early (expected " + std::to_string(width) +
                     "x" + std::to_string(height) + "x" + std::to_string(channels) + " floats)");
  }
  cv::Mat image(height, width, channels == 1 ? CV_32FC1 : CV_32FC3);
  std::vector<char> row(row_bytes);
  for (int y = height - 1; y >= 0; --y) {
    if (!in.read(row.data(), static_cast<std::streamsize>(row_bytes))) {
      throw InputError(path.string() + ": PFM data ends early (expected " + std::to_string(width) +
                       "x" + std::to_string(height) + "x" + std::to_string(channels) + " floats)");
    }
    auto* out = image.ptr<float>(y);
    for (std::size_t i = 0; i < row_bytes / 4U; ++i) {
      std::uint32_t bits = 0;
      std::memcpy(&bits, row.data() + 4U * i, 4);
      if (swap) bits = __builtin_bswap32(bits);
      std::memcpy(&out[i], &bits, 4);
    }
    if (channels == 3) {  // PFM is RGB; OpenCV keeps BGR
      for (int x = 0; x < width; ++x) std::swap(out[3 * x], out[3 * x + 2]);
    }
  }
  return image;
}

void write_pfm(const fs::path& path, const cv::Mat& image, bool force) {
  if (image.empty()) throw InputError(path.string() + ": cannot write an empty image as PFM");
  if (image.type() != CV_32FC1 && image.type() != CV_32FC3) {
    throw InputError(path.string() + ": PFM holds float images (CV_32FC1 or CV_32FC3)");
  }
  if (fs::exists(path) && !force) {
    std::ifstream probe(path, std::ios::binary);
    char magic[2] = {0, 0};
    probe.read(magic, 2);
    if (!(magic[0] == 'P' && (magic[1] == 'f' || magic[1] == 'F'))) {
      throw InputError(path.string() +
                       ": exists and is not a PFM file; not overwritten "
                       "(use --force)");
    }
  }
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(path.string() + ": cannot write");
  const int channels = image.channels();
  out << (channels == 1 ? "Pf" : "PF") << "\n"
      << image.cols << " " << image.rows << "\n"
      << (std::endian::native == std::endian::little ? "-1.0" : "1.0") << "\n";
  std::vector<float> row(static_cast<std::size_t>(image.cols) * static_cast<std::size_t>(channels));
  for (int y = image.rows - 1; y >= 0; --y) {
    std::memcpy(row.data(), image.ptr<float>(y), row.size() * sizeof(float));
    if (channels == 3) {
      for (int x = 0; x < image.cols; ++x)
        std::swap(row[3 * static_cast<std::size_t>(x)], row[3 * static_cast<std::size_t>(x) + 2]);
    }
    out.write(reinterpret_cast<const char*>(row.data()),
              static_cast<std::streamsize>(row.size() * sizeof(float)));
  }
  if (!out) throw InputError(path.string() + ": write failed");
}

}  // namespace kestrel::io
