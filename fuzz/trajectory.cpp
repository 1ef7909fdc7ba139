// Trajectory files: TUM ("timestamp tx ty tz qx qy qz qw") and EuRoC CSV, each parser on every
// input, and the format detection `kestrel evaluate` uses.
#include "fuzz_input.hpp"
#include "kestrel/io/trajectory_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static kestrel::fuzz::InputFile file("trajectory.txt");
  const auto& path = file.write(data, size);
  kestrel::fuzz::expect_parsed_or_refused([&] { (void)kestrel::io::read_tum_trajectory(path); });
  kestrel::fuzz::expect_parsed_or_refused([&] { (void)kestrel::io::read_euroc_trajectory(path); });
  kestrel::fuzz::expect_parsed_or_refused([&] { (void)kestrel::io::read_trajectory(path); });
  return 0;
}
