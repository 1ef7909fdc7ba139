// Stereo peers in one run, one thread: Kestrel's block matcher beside OpenCV StereoBM and
// StereoSGBM on the Middlebury pairs (bad-pixel rate, > 1 px or missing, over pixels with known
// truth), the speed per 752x480 EuRoC pair (64 disparities, block 9, rectification excluded)
// and the fill rate over the EuRoC V1_01 part. Usage: kestrel_bench_stereo [DATA_DIR] [--quick]
// [--speed]
#include <hwy/targets.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <exception>
#include <filesystem>
#include <functional>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/core/stopwatch.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/lab/stereo_evaluation.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/rectification.hpp"

namespace fs = std::filesystem;
using kestrel::sensor::BlockMatcher;
using kestrel::sensor::BlockMatcherOptions;

namespace {

constexpr int kBlock = 9;

cv::Mat gray(const cv::Mat& m) {
  if (m.channels() == 1) return m;
  cv::Mat g;
  cv::cvtColor(m, g, cv::COLOR_BGR2GRAY);
  return g;
}

/// OpenCV fixed-point disparity (x16) to float px, +inf where invalid.
cv::Mat from_fixed(const cv::Mat& d16) {
  cv::Mat out(d16.size(), CV_32F);
  for (int y = 0; y < d16.rows; ++y) {
    for (int x = 0; x < d16.cols; ++x) {
      const short v = d16.at<short>(y, x);
      out.at<float>(y, x) = v < 0 ? kestrel::sensor::kNoDisparity : float(v) / 16.0F;
    }
  }
  return out;
}

struct Peer {
  std::string name;
  std::function<cv::Mat(const cv::Mat&, const cv::Mat&, int)> run;  // grey L, R, num disp
};

cv::Ptr<cv::StereoBM> make_bm(int num) { return cv::StereoBM::create(num, kBlock); }
cv::Ptr<cv::StereoSGBM> make_sgbm(int num) {
  return cv::StereoSGBM::create(0, num, kBlock, 8 * kBlock * kBlock, 32 * kBlock * kBlock);
}

BlockMatcherOptions kestrel_options(int num, kestrel::sensor::MatchingCost cost, bool filters,
                                    int block = kBlock) {
  BlockMatcherOptions o;
  o.max_disparity = num;
  o.block_size = block;
  o.cost = cost;
  if (!filters) {
    o.lr_max_diff = -1;
    o.uniqueness_ratio = 0;
    o.texture_threshold = 0.0;
  }
  return o;
}

// KESTREL_BENCH_SIMD=<target> (e.g. AVX2) runs the block matcher's kernels on that SIMD target
// instead of the CPU's best, to compare targets in one binary.
void choose_simd_target() {
  const char* wanted = std::getenv("KESTREL_BENCH_SIMD");
  if (wanted == nullptr) return;
  for (const std::int64_t t : kestrel::sensor::block_matching_simd_targets()) {
    if (std::string(hwy::TargetName(t)) == wanted) {
      hwy::SetSupportedTargetsForTest(t);
      return;
    }
  }
  throw std::runtime_error(std::string("KESTREL_BENCH_SIMD: no target ") + wanted);
}

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * double(ts.tv_sec) + 1e-6 * double(ts.tv_nsec);
}

/// Median wall-clock and median thread-CPU milliseconds (CPU time is the fairer figure on a
/// shared machine: every peer runs on this thread).
std::pair<double, double> time_ms(const std::function<void()>& f, int repeats) {
  f();  // warm up: sizes buffers
  std::vector<double> wall, cpu;
  for (int i = 0; i < repeats; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = thread_cpu_ms();
    f();
    cpu.push_back(thread_cpu_ms() - c0);
    wall.push_back(kestrel::ms_since(t0));
  }
  std::sort(wall.begin(), wall.end());
  std::sort(cpu.begin(), cpu.end());
  return {wall[wall.size() / 2], cpu[cpu.size() / 2]};
}

void print_time(const char* name, std::pair<double, double> t) {
  std::printf("  %-22s %8.2f ms/pair wall, %8.2f ms/pair thread CPU\n", name, t.first, t.second);
}

void print_usage(std::FILE* to) {
  std::fprintf(to,
               "usage: kestrel_bench_stereo [DATA_DIR] [--quick] [--speed]\n"
               "  DATA_DIR  folder with middlebury/{tsukuba,venus,teddy} and\n"
               "            euroc/V1_01_easy_part1 (default: %s)\n"
               "  --quick   5 EuRoC pairs and 5 timing repeats instead of all pairs and 30\n"
               "  --speed   Kestrel's speed rows only (no Middlebury, no peers, no fill rate)\n"
               "  --help    this text\n",
               KESTREL_DEFAULT_DATA_DIR);
}

int run(const fs::path& data, bool quick, bool speed_only) {
  cv::setNumThreads(0);  // OpenCV runs sequentially: one core for every peer
  using kestrel::sensor::MatchingCost;

  std::vector<Peer> peers;
  peers.push_back({"kestrel sad", [](const cv::Mat& l, const cv::Mat& r, int n) {
                     BlockMatcher m(kestrel_options(n, MatchingCost::kSad, true));
                     return m.match(l, r);
                   }});
  peers.push_back({"kestrel sad dense", [](const cv::Mat& l, const cv::Mat& r, int n) {
                     BlockMatcher m(kestrel_options(n, MatchingCost::kSad, false));
                     return m.match(l, r);
                   }});
  peers.push_back({"kestrel census", [](const cv::Mat& l, const cv::Mat& r, int n) {
                     BlockMatcher m(kestrel_options(n, MatchingCost::kCensus, true));
                     return m.match(l, r);
                   }});
  peers.push_back({"kestrel census dense", [](const cv::Mat& l, const cv::Mat& r, int n) {
                     BlockMatcher m(kestrel_options(n, MatchingCost::kCensus, false));
                     return m.match(l, r);
                   }});
  peers.push_back({"opencv StereoBM", [](const cv::Mat& l, const cv::Mat& r, int n) {
                     cv::Mat d;
                     make_bm(n)->compute(l, r, d);
                     return from_fixed(d);
                   }});
  peers.push_back({"opencv StereoSGBM", [](const cv::Mat& l, const cv::Mat& r, int n) {
                     cv::Mat d;
                     make_sgbm(n)->compute(l, r, d);
                     return from_fixed(d);
                   }});

  // --- Middlebury: bad pixels (> 1 px or missing) over pixels with known truth.
  if (!fs::is_directory(data)) {
    throw kestrel::InputError("DATA_DIR '" + data.string() + "' is not a folder");
  }
  std::vector<kestrel::lab::MiddleburyPair> pairs;
  for (const char* name : {"tsukuba", "venus", "teddy"}) {
    if (speed_only) break;
    pairs.push_back(kestrel::lab::load_middlebury_pair(data / "middlebury" / name));
  }
  if (!speed_only) {
    std::printf(
        "Middlebury, block %d, one thread: bad pixels %% (> 1 px error or no disparity) / fill "
        "%%\n",
        kBlock);
    std::printf("%-22s %16s %16s %16s\n", "matcher", "tsukuba", "venus", "teddy");
  }
  for (const auto& peer : peers) {
    if (speed_only) break;
    std::printf("%-22s", peer.name.c_str());
    for (const auto& p : pairs) {
      const int num = (p.max_disparity + 1 + 15) / 16 * 16;  // OpenCV needs multiples of 16
      const cv::Mat d = peer.run(gray(p.left), gray(p.right), num);
      const auto s = kestrel::lab::score_disparity(d, p.truth_px, 1.0);
      std::printf("   %6.1f / %5.1f", 100.0 * s.bad_rate(), 100.0 * s.fill_rate());
    }
    std::printf("\n");
  }

  // --- EuRoC: speed per rectified pair and fill rate over the part.
  const fs::path euroc = data / "euroc" / "V1_01_easy_part1";
  if (!fs::exists(euroc)) {
    std::printf("EuRoC data not found at %s: speed and fill rate skipped\n",
                euroc.string().c_str());
    return 0;
  }
  kestrel::io::EurocSequence seq(euroc);
  const auto calib = kestrel::sensor::StereoCalibration::from_euroc(seq);
  kestrel::sensor::StereoRectifier rectifier(calib);
  const auto& rig = rectifier.rig();
  std::printf("\nEuRoC V1_01_easy_part1: rectified f %.1f px, baseline %.4f m, %dx%d, %zu pairs\n",
              rig.f, rig.baseline_m, rig.width, rig.height, seq.stereo_size());
  const int num = 64;
  std::vector<std::pair<cv::Mat, cv::Mat>> rectified;
  const std::size_t n_pairs =
      quick ? std::min<std::size_t>(5, seq.stereo_size()) : seq.stereo_size();
  for (std::size_t i = 0; i < n_pairs; ++i) {
    const auto s = seq.load_stereo(i);
    cv::Mat l, r;
    rectifier.rectify(s.left, s.right, l, r);
    rectified.emplace_back(l, r);
  }
  const auto& [l0, r0] = rectified.front();
  const int repeats = quick ? 5 : 30;
  BlockMatcher sad(kestrel_options(num, MatchingCost::kSad, true));
  BlockMatcher sad_dense(kestrel_options(num, MatchingCost::kSad, false));
  BlockMatcher census(kestrel_options(num, MatchingCost::kCensus, true));
  cv::Mat d;
  auto bm = make_bm(num);
  auto sgbm = make_sgbm(num);
  cv::Mat d16;
  choose_simd_target();
  std::printf("speed, %dx%d, %d disparities, block %d, one thread (median of %d), SIMD %s:\n",
              l0.cols, l0.rows, num, kBlock, repeats,
              kestrel::sensor::block_matching_simd_target());
  print_time("kestrel sad", time_ms([&] { sad.match(l0, r0, d); }, repeats));
  print_time("kestrel sad dense", time_ms([&] { sad_dense.match(l0, r0, d); }, repeats));
  print_time("kestrel census", time_ms([&] { census.match(l0, r0, d); }, repeats));
  // The general scan (more than 64 lanes): 128 disparities, block 15.
  BlockMatcher sad_wide(kestrel_options(128, MatchingCost::kSad, true, 15));
  print_time("kestrel sad 128 blk 15", time_ms([&] { sad_wide.match(l0, r0, d); }, repeats));
  if (speed_only) return 0;
  print_time("opencv StereoBM", time_ms([&] { bm->compute(l0, r0, d16); }, repeats));
  print_time("opencv StereoSGBM",
             time_ms([&] { sgbm->compute(l0, r0, d16); }, std::max(3, repeats / 5)));

  std::printf("fill rate over %zu rectified pairs (share of all pixels with a disparity):\n",
              rectified.size());
  for (const auto& peer : peers) {
    double filled = 0.0, total = 0.0;
    for (const auto& [l, r] : rectified) {
      const cv::Mat disp = peer.run(l, r, num);
      for (int y = 0; y < disp.rows; ++y) {
        for (int x = 0; x < disp.cols; ++x)
          filled += std::isfinite(disp.at<float>(y, x)) ? 1.0 : 0.0;
      }
      total += double(disp.total());
    }
    std::printf("  %-22s %6.1f %%\n", peer.name.c_str(), 100.0 * filled / total);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  fs::path data = KESTREL_DEFAULT_DATA_DIR;
  bool quick = false, speed_only = false, have_data = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--quick") {
      quick = true;
    } else if (arg == "--speed") {
      speed_only = true;
    } else if (arg == "--help" || arg == "-h") {
      print_usage(stdout);
      return 0;
    } else if (arg.starts_with("-")) {
      std::fprintf(stderr, "kestrel_bench_stereo: error: unknown option '%s'\n", arg.c_str());
      print_usage(stderr);
      return 2;
    } else if (have_data) {
      std::fprintf(stderr, "kestrel_bench_stereo: error: more than one DATA_DIR ('%s', '%s')\n",
                   data.string().c_str(), arg.c_str());
      print_usage(stderr);
      return 2;
    } else {
      data = arg;
      have_data = true;
    }
  }
  try {
    return run(data, quick, speed_only);
  } catch (const kestrel::InputError& e) {
    std::fprintf(stderr, "kestrel_bench_stereo: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kestrel_bench_stereo: error: %s\n", e.what());
    return 1;
  }
}
