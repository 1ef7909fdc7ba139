// The per-frame log of `kestrel odometry --frames`, read back by `kestrel fuse --vo-frames`.
#include "kestrel/io/odometry_frame_log.hpp"

#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static kestrel::fuzz::InputFile file("frames.csv");
  const auto& path = file.write(data, size);
  kestrel::fuzz::expect_parsed_or_refused(
      [&] { (void)kestrel::io::read_odometry_frame_log(path); });
  return 0;
}
