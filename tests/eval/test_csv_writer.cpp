// CsvWriter: provenance line, header, numbers, quoted text cells, row-length check, and the
// refusal to overwrite a file it did not write.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/eval/csv_writer.hpp"
#include "test_data.hpp"

namespace kestrel::eval {
namespace {

std::string read_all(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(CsvWriter, WritesHeaderNumbersAndQuotedText) {
  const auto dir = test::fresh_temp_dir("csv");
  const auto path = dir / "out.csv";
  CsvWriter csv(path, {"frame", "value", "failure"}, "test", false);
  csv.add(std::int64_t{3}).add(0.25).add(std::string_view("plain"));
  csv.end_row();
  csv.add(std::int64_t{4}).add(-1.5).add(std::string_view("high residual, \"sigma\" 0.2"));
  csv.end_row();
  csv.close();
  const std::string text = read_all(path);
  const auto first_newline = text.find('\n');
  ASSERT_NE(first_newline, std::string::npos);
  EXPECT_EQ(text.substr(0, 1), "#");  // provenance line
  EXPECT_EQ(text.substr(first_newline + 1),
            "frame,value,failure\n3,0.25,plain\n4,-1.5,\"high residual, \"\"sigma\"\" 0.2\"\n");
}

TEST(CsvWriter, ARowOfTheWrongLengthIsALogicError) {
  const auto dir = test::fresh_temp_dir("csv");
  CsvWriter csv(dir / "out.csv", {"a", "b"}, "test", false);
  csv.add(1.0);
  EXPECT_THROW(csv.end_row(), std::logic_error);
}

TEST(CsvWriter, DoesNotOverwriteAForeignFile) {
  const auto dir = test::fresh_temp_dir("csv");
  const auto path = dir / "mine.csv";
  { std::ofstream(path) << "the user's own notes\n"; }
  EXPECT_THROW(CsvWriter(path, {"a"}, "test", false), InputError);
  EXPECT_EQ(read_all(path), "the user's own notes\n");
}

}  // namespace
}  // namespace kestrel::eval
