// `kestrel disparity --backend`: cpu and auto give the same PFM; cuda is an error naming the
// reason without a device, and the same PFM with one; an unknown name is an input error.
#include <gtest/gtest.h>

#include <cstring>
#include <opencv2/imgcodecs.hpp>

#include "kestrel/gpu/backend.hpp"
#include "kestrel/io/pfm.hpp"
#include "run_cli.hpp"
#include "stereo_scenes.hpp"
#include "test_data.hpp"

namespace kestrel::gpu {
namespace {

bool same_bits(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

TEST(CmdDisparityBackend, BackendsGiveTheSameDisparityOrAClearError) {
  const auto dir = kestrel::test::fresh_temp_dir("gpu_cli");
  cv::Mat left, right;
  test::synthetic_pair(160, 96, 9, left, right);
  cv::imwrite((dir / "l.png").string(), left);
  cv::imwrite((dir / "r.png").string(), right);
  const auto run = [&](const std::string& backend, const std::string& out) {
    return kestrel::test::run_kestrel(
        dir, "disparity --left " + kestrel::test::quoted((dir / "l.png").string()) + " --right " +
                 kestrel::test::quoted((dir / "r.png").string()) + " --max-disparity 48 --out " +
                 kestrel::test::quoted((dir / out).string()) + " --backend " + backend);
  };
  const auto cpu = run("cpu", "cpu.pfm");
  ASSERT_EQ(cpu.exit_code, 0) << cpu.err;
  EXPECT_NE(cpu.err.find("backend cpu"), std::string::npos) << cpu.err;
  const auto aut = run("auto", "auto.pfm");
  ASSERT_EQ(aut.exit_code, 0) << aut.err;
  EXPECT_TRUE(same_bits(io::read_pfm(dir / "cpu.pfm"), io::read_pfm(dir / "auto.pfm")));

  const auto cuda = run("cuda", "cuda.pfm");
  if (cuda_device_info().available()) {
    ASSERT_EQ(cuda.exit_code, 0) << cuda.err;
    EXPECT_NE(aut.err.find("backend cuda"), std::string::npos) << aut.err;
    EXPECT_TRUE(same_bits(io::read_pfm(dir / "cpu.pfm"), io::read_pfm(dir / "cuda.pfm")));
  } else {
    EXPECT_NE(aut.err.find("using the CPU"), std::string::npos) << aut.err;
    EXPECT_EQ(cuda.exit_code, 1);
    EXPECT_NE(cuda.err.find("kestrel: error: backend cuda: "), std::string::npos) << cuda.err;
  }
  const auto bad = run("gpu", "bad.pfm");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("--backend"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace kestrel::gpu
