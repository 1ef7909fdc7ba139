// EuRoC IMU CSV (imu0/data.csv), streamed sample by sample as `kestrel fuse` reads it.
#include "fuzz_input.hpp"
#include "kestrel/io/euroc.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static kestrel::fuzz::InputFile file("data.csv");
  const auto& path = file.write(data, size);
  kestrel::fuzz::expect_parsed_or_refused([&] {
    kestrel::io::ImuCsvReader reader(path);
    kestrel::io::ImuSample sample;
    while (reader.next(sample)) {
    }
  });
  return 0;
}
