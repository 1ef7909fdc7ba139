// EuRoC full-state ground truth (state_groundtruth_estimate0/data.csv, 17 columns).
#include "fuzz_input.hpp"
#include "kestrel/io/euroc.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static kestrel::fuzz::InputFile file("data.csv");
  const auto& path = file.write(data, size);
  kestrel::fuzz::expect_parsed_or_refused(
      [&] { (void)kestrel::io::read_euroc_state_groundtruth(path); });
  return 0;
}
