// A fixture for end-to-end tests of the `kestrel` binary: a fresh scratch folder per test
// (named after the test suite, removed afterwards) and run() capturing stdout and stderr there.
#pragma once

#include <gtest/gtest.h>

#include <cctype>
#include <filesystem>
#include <string>

#include "run_cli.hpp"
#include "test_data.hpp"

namespace kestrel::test {

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(std::filesystem::exists(KESTREL_BINARY))
        << KESTREL_BINARY << " not found: build the `kestrel` target first";
    std::string name = ::testing::UnitTest::GetInstance()->current_test_suite()->name();
    for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    dir_ = fresh_temp_dir(name);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  [[nodiscard]] RunResult run(const std::string& arguments) const {
    return run_kestrel(dir_, arguments);
  }

  std::filesystem::path dir_;
};

}  // namespace kestrel::test
