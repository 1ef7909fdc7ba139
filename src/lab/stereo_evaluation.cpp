// Disparity scoring and the Middlebury loader.
#include "kestrel/lab/stereo_evaluation.hpp"

#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"

namespace kestrel::lab {
namespace fs = std::filesystem;

double DisparityScore::bad_rate_of_filled() const {
  const std::size_t missing = scored - filled;
  return filled ? double(bad - missing) / double(filled) : 0.0;
}

std::string DisparityScore::describe() const {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(2);
  os << "fill " << 100.0 * fill_rate() << "%, bad(>" << bad_threshold_px << " px, missing = bad) "
     << 100.0 * bad_rate() << "%, bad of filled " << 100.0 * bad_rate_of_filled() << "%, RMS "
     << rms_error_px << " px over " << scored << " px";
  return os.str();
}

DisparityScore score_disparity(const cv::Mat& disparity_px, const cv::Mat& truth_px,
                               double bad_threshold_px, const cv::Mat& mask) {
  if (disparity_px.type() != CV_32F || truth_px.type() != CV_32F ||
      disparity_px.size() != truth_px.size()) {
    throw std::invalid_argument("score_disparity: need two CV_32F maps of the same size");
  }
  if (!mask.empty() && (mask.type() != CV_8U || mask.size() != truth_px.size())) {
    throw std::invalid_argument("score_disparity: the mask must be CV_8U of the map's size");
  }
  DisparityScore s;
  s.bad_threshold_px = bad_threshold_px;
  double sum_sq = 0.0;
  for (int y = 0; y < truth_px.rows; ++y) {
    const float* d = disparity_px.ptr<float>(y);
    const float* t = truth_px.ptr<float>(y);
    const std::uint8_t* m = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < truth_px.cols; ++x) {
      if (!(std::isfinite(t[x]) && t[x] > 0.0F) || (m != nullptr && m[x] == 0)) continue;
      ++s.scored;
      if (!std::isfinite(d[x])) {
        ++s.bad;
        continue;
      }
      ++s.filled;
      const double e = double(d[x]) - double(t[x]);
      sum_sq += e * e;
      if (std::abs(e) > bad_threshold_px) ++s.bad;
    }
  }
  s.rms_error_px = s.filled ? std::sqrt(sum_sq / double(s.filled)) : 0.0;
  return s;
}

namespace {

cv::Mat read_image(const fs::path& path, int flags) {
  if (!fs::exists(path)) throw InputError(path.string() + ": missing (Middlebury pair file)");
  cv::Mat image = cv::imread(path.string(), flags);
  if (image.empty()) throw InputError(path.string() + ": cannot decode the image");
  return image;
}

}  // namespace

MiddleburyPair load_middlebury_pair(const fs::path& folder) {
  MiddleburyPair pair;
  pair.name = folder.filename().string();
  if (pair.name.empty()) pair.name = folder.parent_path().filename().string();
  std::string left, right, truth;
  double scale = 0.0;
  if (pair.name == "tsukuba") {
    left = "im3.png", right = "im4.png", truth = "disp3.pgm", scale = 16.0, pair.max_disparity = 15;
  } else if (pair.name == "venus") {
    left = "im2.png", right = "im6.png", truth = "disp2.pgm", scale = 8.0, pair.max_disparity = 20;
  } else if (pair.name == "teddy") {
    left = "im2.png", right = "im6.png", truth = "disp2.png", scale = 4.0, pair.max_disparity = 60;
  } else {
    throw InputError(folder.string() + ": unknown Middlebury pair '" + pair.name +
                     "' (known: tsukuba, venus, teddy)");
  }
  pair.left = read_image(folder / left, cv::IMREAD_COLOR);
  pair.right = read_image(folder / right, cv::IMREAD_COLOR);
  const cv::Mat t = read_image(folder / truth, cv::IMREAD_GRAYSCALE);
  t.convertTo(pair.truth_px, CV_32F, 1.0 / scale);
  return pair;
}

cv::Mat colorize_disparity(const cv::Mat& disparity_px, double max_disparity_px) {
  CV_Assert(disparity_px.type() == CV_32F);
  cv::Mat gray(disparity_px.size(), CV_8U);
  cv::Mat valid(disparity_px.size(), CV_8U);
  for (int y = 0; y < disparity_px.rows; ++y) {
    const float* d = disparity_px.ptr<float>(y);
    for (int x = 0; x < disparity_px.cols; ++x) {
      const bool ok = std::isfinite(d[x]);
      valid.at<std::uint8_t>(y, x) = ok ? 255 : 0;
      gray.at<std::uint8_t>(y, x) =
          ok ? cv::saturate_cast<std::uint8_t>(255.0 * double(d[x]) / max_disparity_px) : 0;
    }
  }
  cv::Mat color;
  cv::applyColorMap(gray, color, cv::COLORMAP_TURBO);
  color.setTo(cv::Scalar::all(0), valid == 0);
  return color;
}

}  // namespace kestrel::lab
