// Line reader and strict number parsing: errors must name the file and line.
#include <gtest/gtest.h>

#include <fstream>

#include "kestrel/core/error.hpp"
#include "kestrel/io/text_lines.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "test_data.hpp"

namespace kestrel::io {
namespace {

std::filesystem::path write(const std::filesystem::path& dir, const std::string& text) {
  const auto p = dir / "file.txt";
  std::ofstream(p) << text;
  return p;
}

TEST(TextLineReader, SkipsCommentsAndBlankLinesAndCountsLines) {
  const auto dir = test::fresh_temp_dir("io");
  TextLineReader r(write(dir, "# header\n\n  \n1 2\r\n# mid\n3 4\n"));
  std::string line;
  ASSERT_TRUE(r.next(line));
  EXPECT_EQ(line, "1 2");
  EXPECT_EQ(r.line_number(), 4u);
  ASSERT_TRUE(r.next(line));
  EXPECT_EQ(line, "3 4");
  EXPECT_EQ(r.line_number(), 6u);
  EXPECT_FALSE(r.next(line));
}

TEST(TextLineReader, MissingFileNamesIt) {
  try {
    TextLineReader r("/nonexistent/kestrel/file.txt");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/kestrel/file.txt"), std::string::npos);
  }
}

TEST(SplitFields, WhitespaceRunsAndCommas) {
  const auto ws = split_fields("  a \t b   c ", " \t");
  ASSERT_EQ(ws.size(), 3u);
  EXPECT_EQ(ws[2], "c");
  const auto csv = split_fields("1, 2 ,,4", ",");
  ASSERT_EQ(csv.size(), 4u);
  EXPECT_EQ(csv[1], "2");
  EXPECT_EQ(csv[2], "");
  EXPECT_EQ(split_fields("1,2,", ",").size(), 3u);
}

TEST(ParseNumbers, RejectsGarbageWithFileAndLine) {
  const auto dir = test::fresh_temp_dir("io");
  const auto path = write(dir, "x\n1.5 nan abc 12.000 12.5\n");
  TextLineReader r(path);
  std::string line;
  r.next(line);
  r.next(line);
  const auto f = split_fields(line, " ");
  EXPECT_DOUBLE_EQ(parse_double(f[0], r, 0), 1.5);
  EXPECT_EQ(parse_int64(f[3], r, 3), 12);
  try {
    parse_double(f[1], r, 1);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path.string() + ":2:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("field 2"), std::string::npos);
  }
  EXPECT_THROW(parse_double(f[2], r, 2), InputError);
  EXPECT_THROW(parse_int64(f[4], r, 4), InputError);
}

TEST(ParseSeconds, ExactDecimalToNanoseconds) {
  EXPECT_EQ(parse_seconds_to_ns("1305031102.175304"), 1305031102175304000LL);
  EXPECT_EQ(parse_seconds_to_ns("1305031102.1753040001"), 1305031102175304000LL);
  EXPECT_EQ(parse_seconds_to_ns("1305031102.1753040005"), 1305031102175304001LL);
  EXPECT_EQ(parse_seconds_to_ns("12"), 12000000000LL);
  EXPECT_EQ(parse_seconds_to_ns(".5"), 500000000LL);
  EXPECT_EQ(parse_seconds_to_ns("-1.5"), -1500000000LL);
  EXPECT_FALSE(parse_seconds_to_ns("1e9"));
  EXPECT_FALSE(parse_seconds_to_ns("abc"));
  EXPECT_FALSE(parse_seconds_to_ns(""));
  EXPECT_FALSE(parse_seconds_to_ns("."));
}

}  // namespace
}  // namespace kestrel::io
