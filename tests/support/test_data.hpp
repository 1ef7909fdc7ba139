// Locating the shared real data (../shared/data) from tests; tests that need it skip with a
// clear message where it is absent, as on a machine without the shared folder.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace kestrel::test {

/// The real sequence most tests run on (250 frames of fr1/rpy), relative to shared_data_dir().
inline constexpr const char* kTumRpyPart1 = "tum/rgbd_dataset_freiburg1_rpy_part1";

/// KESTREL_DATA_DIR if set, else the configure-time default (../shared/data).
inline std::filesystem::path shared_data_dir() {
  if (const char* env = std::getenv("KESTREL_DATA_DIR"); env != nullptr && *env != '\0') {
    return env;
  }
  return KESTREL_DEFAULT_DATA_DIR;
}

/// A fresh, empty temporary directory for one test.
inline std::filesystem::path fresh_temp_dir(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::filesystem::path dir = std::filesystem::temp_directory_path() /
                              ("kestrel_test_" + name + "_" + info->test_suite_name() + "_" +
                               info->name() + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace kestrel::test

/// Skips the current test with a message unless `relative` exists under the shared data.
#define KESTREL_REQUIRE_DATA(relative)                                                      \
  do {                                                                                      \
    const auto kestrel_data_path_ = ::kestrel::test::shared_data_dir() / (relative);        \
    if (!std::filesystem::exists(kestrel_data_path_)) {                                     \
      GTEST_SKIP() << "shared data not found: " << kestrel_data_path_.string()              \
                   << " (set KESTREL_DATA_DIR to the shared/data folder to run this test)"; \
    }                                                                                       \
  } while (0)
