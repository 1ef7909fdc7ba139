// PFM images (Middlebury disparity maps, `kestrel disparity` output read back).
#include "kestrel/io/pfm.hpp"

#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static kestrel::fuzz::InputFile file("disp.pfm");
  const auto& path = file.write(data, size);
  kestrel::fuzz::expect_parsed_or_refused([&] { (void)kestrel::io::read_pfm(path); });
  return 0;
}
