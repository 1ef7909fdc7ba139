// Stereo peers in one run, one thread: Kestrel's block matcher and semi-global matcher beside
// OpenCV StereoBM and StereoSGBM on the Middlebury pairs (2001/2003: tsukuba, venus, teddy; and
// the 2014 training scenes, scored on their non-occluded pixels): bad-pixel rate (> 1 px or
// missing, over pixels with known truth) and fill; the speed per 752x480 EuRoC pair (64
// disparities, block 9, rectification excluded) and the fill rate over the EuRoC V1_01 part.
// Usage: kestrel_bench_stereo [DATA_DIR] [--quick] [--speed] [--row NAME] [--sgm-vs-sgbm]
#include <hwy/targets.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/core/stopwatch.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/io/pfm.hpp"
#include "kestrel/lab/stereo_evaluation.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/rectification.hpp"
#include "kestrel/sensor/sgm_matcher.hpp"

namespace fs = std::filesystem;
using kestrel::sensor::BlockMatcher;
using kestrel::sensor::BlockMatcherOptions;
using kestrel::sensor::SgmMatcher;
using kestrel::sensor::SgmOptions;

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

/// One scored pair: its views, the true disparity (0 or non-finite = unknown), the pixels
/// scored (empty: all with a known truth) and the disparities searched (a multiple of 16, as
/// OpenCV needs).
struct ScoredPair {
  std::string name;
  cv::Mat left, right, truth, mask;
  int num_disparities = 0;
};

int multiple_of_16(int n) { return (n + 15) / 16 * 16; }

/// A Middlebury 2014 scene folder: im0/im1, disp0GT.pfm (inf = unknown), mask0nocc.png (255 =
/// non-occluded: the pixels scored), ndisp from calib.txt (Scharstein et al., GCPR 2014).
ScoredPair load_middlebury2014(const fs::path& folder) {
  ScoredPair p;
  p.name = folder.filename().string();
  p.left = cv::imread((folder / "im0.png").string(), cv::IMREAD_GRAYSCALE);
  p.right = cv::imread((folder / "im1.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat mask = cv::imread((folder / "mask0nocc.png").string(), cv::IMREAD_GRAYSCALE);
  if (p.left.empty() || p.right.empty() || mask.empty()) {
    throw kestrel::InputError(folder.string() + ": im0.png, im1.png or mask0nocc.png missing");
  }
  p.truth = kestrel::io::read_pfm(folder / "disp0GT.pfm");
  p.mask = mask == 255;
  std::ifstream calib(folder / "calib.txt");
  std::string line;
  int ndisp = 0;
  while (std::getline(calib, line)) {
    const auto at = line.find("ndisp=");  // lines may start with blanks
    if (at != std::string::npos) ndisp = std::stoi(line.substr(at + 6));
  }
  if (ndisp <= 0) throw kestrel::InputError(folder.string() + "/calib.txt: no ndisp");
  p.num_disparities = multiple_of_16(ndisp);
  return p;
}

std::vector<ScoredPair> load_scored_pairs(const fs::path& data) {
  std::vector<ScoredPair> pairs;
  for (const char* name : {"tsukuba", "venus", "teddy"}) {
    auto m = kestrel::lab::load_middlebury_pair(data / "middlebury" / name);
    pairs.push_back({m.name, gray(m.left), gray(m.right), m.truth_px, cv::Mat(),
                     multiple_of_16(m.max_disparity + 1)});
  }
  const fs::path m2014 = data / "middlebury2014";
  if (!fs::is_directory(m2014)) {
    std::printf("Middlebury 2014 not found at %s: its scenes skipped\n", m2014.string().c_str());
    return pairs;
  }
  std::vector<fs::path> scenes;
  for (const auto& e : fs::directory_iterator(m2014)) {
    if (e.is_directory()) scenes.push_back(e.path());
  }
  std::sort(scenes.begin(), scenes.end());
  for (const auto& scene : scenes) pairs.push_back(load_middlebury2014(scene));
  return pairs;
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

/// The semi-global matcher with its defaults over `num` disparities (one set for every scene),
/// or with its left-right check on (tolerance 1 px). KESTREL_BENCH_SGM_PATHS=4 measures the
/// 4-path variant (speed and quality) without another binary.
SgmOptions sgm_options(int num, bool checked = false) {
  SgmOptions o;
  o.max_disparity = num;
  if (const char* paths = std::getenv("KESTREL_BENCH_SGM_PATHS")) o.paths = std::atoi(paths);
  if (checked) o.lr_max_diff = 1;
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
               "usage: kestrel_bench_stereo [DATA_DIR] [--quick] [--speed] [--row NAME] "
               "[--sgm-vs-sgbm]\n"
               "  DATA_DIR  folder with middlebury/{tsukuba,venus,teddy}, middlebury2014/<scene>\n"
               "            and euroc/V1_01_easy_part1 (default: %s)\n"
               "  --quick   5 EuRoC pairs and 5 timing repeats instead of all pairs and 30\n"
               "  --speed   Kestrel's speed rows only (no Middlebury, no peers, no fill rate)\n"
               "  --row NAME  with --speed: that speed row only (e.g. 'kestrel census'), to\n"
               "            profile one matcher (scripts/instruction_counts.sh)\n"
               "  --sgm-vs-sgbm  only kestrel sgm and OpenCV StereoSGBM on one EuRoC pair, one\n"
               "            match of each in turn (30 rounds; --quick 5): both medians and their\n"
               "            ratio, thread CPU (the fair comparison on a loaded machine)\n"
               "  --help    this text\n",
               KESTREL_DEFAULT_DATA_DIR);
}

/// Every matcher of the comparison, each run with its options for a given disparity count.
std::vector<Peer> make_peers() {
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
  peers.push_back({"kestrel sgm", [](const cv::Mat& l, const cv::Mat& r, int n) {
                     SgmMatcher m(sgm_options(n));
                     return m.match(l, r);
                   }});
  peers.push_back({"kestrel sgm lr", [](const cv::Mat& l, const cv::Mat& r, int n) {
                     SgmMatcher m(sgm_options(n, true));
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
  return peers;
}

/// The bad-pixel table: a row per Middlebury scene, a column per peer.
void print_middlebury_table(const std::vector<Peer>& peers, const fs::path& data) {
  // --- Middlebury: bad pixels (> 1 px or missing) over pixels with known truth.
  if (!fs::is_directory(data)) {
    throw kestrel::InputError("DATA_DIR '" + data.string() + "' is not a folder");
  }
  const std::vector<ScoredPair> pairs = load_scored_pairs(data);
  std::printf(
      "Middlebury, block %d, one thread: bad pixels %% (> 1 px error or no disparity, "
      "2014: non-occluded pixels) / fill %%; disparities searched in brackets\n",
      kBlock);
  std::printf("%-18s", "scene");
  for (const auto& peer : peers) std::printf(" %20s", peer.name.c_str());
  std::printf("\n");
  for (const auto& p : pairs) {
    std::printf("%-12s (%3d)", p.name.c_str(), p.num_disparities);
    for (const auto& peer : peers) {
      const cv::Mat d = peer.run(p.left, p.right, p.num_disparities);
      const auto s = kestrel::lab::score_disparity(d, p.truth, 1.0, p.mask);
      std::printf("        %5.1f / %5.1f", 100.0 * s.bad_rate(), 100.0 * s.fill_rate());
    }
    std::printf("\n");
    std::fflush(stdout);
  }
}

/// kestrel sgm and StereoSGBM alternately, one match each per round, so that both see the same
/// load: thread-CPU medians and their ratio.
void sgm_vs_sgbm(const cv::Mat& l, const cv::Mat& r, int num, int rounds) {
  SgmMatcher sgm(sgm_options(num));
  auto sgbm = make_sgbm(num);
  cv::Mat d, d16;
  sgm.match(l, r, d);  // warm up: sizes buffers
  sgbm->compute(l, r, d16);
  std::vector<double> a, b;
  for (int i = 0; i < rounds; ++i) {
    double c0 = thread_cpu_ms();
    sgm.match(l, r, d);
    a.push_back(thread_cpu_ms() - c0);
    c0 = thread_cpu_ms();
    sgbm->compute(l, r, d16);
    b.push_back(thread_cpu_ms() - c0);
  }
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  const double ma = a[a.size() / 2], mb = b[b.size() / 2];
  std::printf(
      "sgm vs SGBM, %dx%d, %d disparities, one thread, %d alternate rounds, thread CPU "
      "(kernels %s): kestrel sgm %.2f ms, opencv StereoSGBM %.2f ms, ratio %.3f\n",
      l.cols, l.rows, num, rounds, SgmMatcher::simd_target(), ma, mb, ma / mb);
}

int run(const fs::path& data, bool quick, bool speed_only, const std::string& only_row,
        bool vs_sgbm) {
  cv::setNumThreads(0);  // OpenCV runs sequentially: one core for every peer
  using kestrel::sensor::MatchingCost;

  const std::vector<Peer> peers = make_peers();
  if (!speed_only) print_middlebury_table(peers, data);

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
  if (vs_sgbm) {
    choose_simd_target();
    sgm_vs_sgbm(l0, r0, num, repeats);
    return 0;
  }
  BlockMatcher sad(kestrel_options(num, MatchingCost::kSad, true));
  BlockMatcher sad_dense(kestrel_options(num, MatchingCost::kSad, false));
  BlockMatcher census(kestrel_options(num, MatchingCost::kCensus, true));
  SgmMatcher sgm(sgm_options(num));
  SgmMatcher sgm_lr(sgm_options(num, true));
  cv::Mat d;
  auto bm = make_bm(num);
  auto sgbm = make_sgbm(num);
  cv::Mat d16;
  choose_simd_target();
  std::printf("speed, %dx%d, %d disparities, block %d, one thread (median of %d), SIMD %s:\n",
              l0.cols, l0.rows, num, kBlock, repeats,
              kestrel::sensor::block_matching_simd_target());
  bool row_found = false;
  const auto row = [&](const char* name, const std::function<void()>& f) {
    if (!only_row.empty() && only_row != name) return;
    row_found = true;
    print_time(name, time_ms(f, repeats));
  };
  row("kestrel sad", [&] { sad.match(l0, r0, d); });
  row("kestrel sad dense", [&] { sad_dense.match(l0, r0, d); });
  row("kestrel census", [&] { census.match(l0, r0, d); });
  // The general scan (more than 64 lanes): 128 disparities, block 15.
  BlockMatcher sad_wide(kestrel_options(128, MatchingCost::kSad, true, 15));
  row("kestrel sad 128 blk 15", [&] { sad_wide.match(l0, r0, d); });
  row("kestrel sgm", [&] { sgm.match(l0, r0, d); });
  row("kestrel sgm lr", [&] { sgm_lr.match(l0, r0, d); });
  std::printf("  (kestrel sgm kernels: %s)\n", SgmMatcher::simd_target());
  if (!row_found) {
    throw std::invalid_argument("--row '" + only_row +
                                "': no such speed row (kestrel sad, kestrel sad dense, kestrel "
                                "census, kestrel sad 128 blk 15, kestrel sgm, kestrel sgm lr)");
  }
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
  bool quick = false, speed_only = false, have_data = false, vs_sgbm = false;
  std::string only_row;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--quick") {
      quick = true;
    } else if (arg == "--speed") {
      speed_only = true;
    } else if (arg == "--sgm-vs-sgbm") {
      vs_sgbm = true;
      speed_only = true;
    } else if (arg == "--row" && i + 1 < argc) {
      only_row = argv[++i];
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
    if (!only_row.empty() && !speed_only) {
      std::fprintf(stderr, "kestrel_bench_stereo: error: --row needs --speed\n");
      return 2;
    }
    return run(data, quick, speed_only, only_row, vs_sgbm);
  } catch (const kestrel::InputError& e) {
    std::fprintf(stderr, "kestrel_bench_stereo: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kestrel_bench_stereo: error: %s\n", e.what());
    return 1;
  }
}
