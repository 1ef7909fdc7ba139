// Recording stereo frames in the EuRoC layout, one frame at a time.
#include "kestrel/driver/stereo_recorder.hpp"

#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/io/output_guard.hpp"

namespace kestrel::driver {

namespace fs = std::filesystem;

namespace {

bool holds_previous_capture(const fs::path& dir) {
  std::ifstream in(dir / ".kestrel-output");
  std::string line;
  return in && std::getline(in, line) && line == StereoRecorder::kCommand;
}

std::ofstream open_csv(const fs::path& path) {
  std::ofstream out(path);
  if (!out) throw InputError(path.string() + ": cannot open file for writing");
  out << io::provenance_line(StereoRecorder::kCommand) << "\n#timestamp [ns],filename\n";
  return out;
}

void check_stream(std::ofstream& out, const fs::path& path) {
  out.flush();
  if (!out) throw InputError(path.string() + ": write failed (disk full?)");
}

}  // namespace

void RecorderOptions::validate() const {
  if (png_compression < 0 || png_compression > 9) {
    throw std::invalid_argument("recorder: png_compression must be in 0..9");
  }
}

std::string RecorderOptions::describe() const {
  std::ostringstream os;
  os << view_kind_name(images) << " PNGs (deflate " << png_compression << ")"
     << (raw ? ", raw packed frames kept" : "");
  return os.str();
}

StereoRecorder::StereoRecorder(fs::path dir, StereoDecoderOptions decoder, RecorderOptions options,
                               bool force)
    : dir_(std::move(dir)), decoder_(decoder), options_(options) {
  options_.validate();
  const bool previous = fs::exists(dir_) && holds_previous_capture(dir_);
  io::claim_output_dir(dir_, kCommand, force);
  if (previous) {
    for (const char* sub : {"mav0", "raw"}) fs::remove_all(dir_ / sub);
  }
  for (const char* sub : {"mav0/cam0/data", "mav0/cam1/data"}) fs::create_directories(dir_ / sub);
  if (options_.raw) fs::create_directories(dir_ / "raw");
  cam0_csv_ = open_csv(dir_ / "mav0" / "cam0" / "data.csv");
  cam1_csv_ = open_csv(dir_ / "mav0" / "cam1" / "data.csv");
}

StereoRecorder::~StereoRecorder() {
  if (finished_) return;
  try {
    finish();
  } catch (...) {  // NOLINT(bugprone-empty-catch): a destructor must not throw
  }
}

void StereoRecorder::write(TimeNs t_ns, const StereoMosaic& mosaic,
                           std::span<const std::uint8_t> packed, std::size_t bytes_per_line) {
  if (finished_) throw std::logic_error("StereoRecorder: write after finish()");
  if (last_t_ns_ && t_ns <= *last_t_ns_) {
    throw std::invalid_argument("StereoRecorder: time stamps must increase (" +
                                std::to_string(t_ns) + " after " + std::to_string(*last_t_ns_) +
                                ")");
  }
  if (options_.raw && packed.empty()) {
    throw std::invalid_argument("StereoRecorder: raw recording needs the packed frame");
  }
  const std::vector<int> params{cv::IMWRITE_PNG_COMPRESSION, options_.png_compression};
  const std::string name = std::to_string(t_ns) + ".png";
  const std::pair<const cv::Mat*, const char*> views[] = {{&mosaic.left, "cam0"},
                                                          {&mosaic.right, "cam1"}};
  for (const auto& [view, cam] : views) {
    decoder_.convert(*view, options_.images, view_);
    const fs::path file = dir_ / "mav0" / cam / "data" / name;
    if (!cv::imwrite(file.string(), view_, params)) {
      throw InputError(file.string() + ": cannot write image");
    }
  }
  if (options_.raw) {
    write_raw(dir_ / "raw" / (std::to_string(t_ns) + ".bin"), packed, bytes_per_line);
  }
  cam0_csv_ << t_ns << ',' << name << '\n';
  cam1_csv_ << t_ns << ',' << name << '\n';
  last_t_ns_ = t_ns;
  ++frames_;
}

void StereoRecorder::write_raw(const fs::path& path, std::span<const std::uint8_t> packed,
                               std::size_t bytes_per_line) const {
  const std::size_t row = decoder_.options().packed_row_bytes();
  const std::size_t step = bytes_per_line == 0 ? row : bytes_per_line;
  if (!decoder_.check(packed.size(), step).ok()) {
    throw std::invalid_argument("StereoRecorder: the packed frame is too short");
  }
  std::ofstream out(path, std::ios::binary);
  for (int y = 0; y < decoder_.options().height; ++y) {
    const auto* begin = packed.data() + static_cast<std::size_t>(y) * step;
    out.write(reinterpret_cast<const char*>(begin),  // NOLINT(*-reinterpret-cast): bytes
              static_cast<std::streamsize>(row));
  }
  out.flush();
  if (!out) throw InputError(path.string() + ": cannot write (disk full?)");
}

void StereoRecorder::finish() {
  if (finished_) return;
  finished_ = true;
  check_stream(cam0_csv_, dir_ / "mav0" / "cam0" / "data.csv");
  check_stream(cam1_csv_, dir_ / "mav0" / "cam1" / "data.csv");
  cam0_csv_.close();
  cam1_csv_.close();
}

}  // namespace kestrel::driver
