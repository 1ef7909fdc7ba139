// Reading the per-frame odometry log back: columns by name, bad values by line and field.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/io/odometry_frame_log.hpp"
#include "test_data.hpp"

namespace kestrel::io {
namespace {

std::string header(bool with_cov) {
  std::ostringstream h;
  h << "frame,t_ns,ref_t_ns,ok,failure,new_keyframe";
  if (with_cov) {
    for (int r = 0; r < 6; ++r) {
      for (int c = r; c < 6; ++c) h << ',' << frame_log_covariance_column(r, c);
    }
  }
  h << '\n';
  return h.str();
}

// A row with covariance diag(d) and off-diagonal (0, 3) = x.
std::string row(int frame, long long t, long long ref, int ok, int kf, double d, double x) {
  std::ostringstream s;
  s << frame << ',' << t << ',' << ref << ',' << ok << ',' << (ok ? "" : "no_overlap") << ',' << kf;
  for (int r = 0; r < 6; ++r) {
    for (int c = r; c < 6; ++c) s << ',' << (r == c ? d : (r == 0 && c == 3 ? x : 0.0));
  }
  s << '\n';
  return s.str();
}

TEST(OdometryFrameLog, ReadsReferencesFlagsAndTheSymmetricCovariance) {
  const auto dir = test::fresh_temp_dir("frame_log");
  const auto p = dir / "f.csv";
  std::ofstream(p) << "# written by kestrel odometry\n"
                   << header(true) << row(0, 100, 100, 1, 1, 0.0, 0.0)
                   << row(1, 200, 100, 1, 0, 2.0, 0.5) << row(2, 300, 100, 0, 1, 1.0, 0.0);
  const auto rows = read_odometry_frame_log(p);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[1].t_ns, 200);
  EXPECT_EQ(rows[1].ref_t_ns, 100);
  EXPECT_TRUE(rows[1].ok);
  EXPECT_FALSE(rows[1].new_keyframe);
  EXPECT_DOUBLE_EQ(rows[1].covariance(2, 2), 2.0);
  EXPECT_DOUBLE_EQ(rows[1].covariance(0, 3), 0.5);
  EXPECT_DOUBLE_EQ(rows[1].covariance(3, 0), 0.5);
  EXPECT_FALSE(rows[2].ok);
  EXPECT_TRUE(rows[2].new_keyframe);
}

TEST(OdometryFrameLog, ErrorsNameTheFileTheColumnOrTheLine) {
  const auto dir = test::fresh_temp_dir("frame_log");
  auto error_of = [&](const std::string& name, const std::string& text) {
    const auto p = dir / name;
    std::ofstream(p) << text;
    try {
      (void)read_odometry_frame_log(p);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of("a.csv", header(false) + "1,100,100,1,,1\n").find("no column 'cov_00'"),
            std::string::npos);
  // Not positive-definite on an ok row with a reference: line 2 named.
  const std::string npd = error_of("b.csv", header(true) + row(1, 200, 100, 1, 0, 1.0, 3.0));
  EXPECT_NE(npd.find("b.csv:2"), std::string::npos) << npd;
  EXPECT_NE(npd.find("positive-definite"), std::string::npos) << npd;
  EXPECT_NE(error_of("c.csv", header(true) + row(1, 200, 100, 2, 0, 1.0, 0.0)).find("0 or 1"),
            std::string::npos);
  EXPECT_NE(error_of("d.csv", header(true) + row(1, 200, 100, 1, 0, 1.0, 0.0) +
                                  row(2, 200, 100, 1, 0, 1.0, 0.0))
                .find("does not increase"),
            std::string::npos);
  EXPECT_NE(error_of("e.csv", header(true) + "1,200\n").find("fields"), std::string::npos);
}

}  // namespace
}  // namespace kestrel::io
