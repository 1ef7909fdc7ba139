// EuRoC camera index (cam0/data.csv: "timestamp [ns],filename").
#include "fuzz_input.hpp"
#include "kestrel/io/euroc.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static kestrel::fuzz::InputFile file("data.csv");
  const auto& path = file.write(data, size);
  kestrel::fuzz::expect_parsed_or_refused([&] { (void)kestrel::io::read_euroc_camera_csv(path); });
  return 0;
}
