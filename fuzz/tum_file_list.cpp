// TUM RGB-D lists (rgb.txt, depth.txt: "timestamp filename"), and the association of two lists
// by time as the odometry does with rgb.txt and depth.txt.
#include <algorithm>

#include "fuzz_input.hpp"
#include "kestrel/io/tum_rgbd.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static kestrel::fuzz::InputFile file("rgb.txt");
  const auto& path = file.write(data, size);
  kestrel::fuzz::expect_parsed_or_refused([&] {
    const auto list = kestrel::io::read_tum_file_list(path);
    std::vector<kestrel::TimeNs> t;
    for (const auto& entry : list) t.push_back(entry.t_ns);
    // The list against itself shifted by 10 ms, with the benchmark's 20 ms tolerance.
    std::vector<kestrel::TimeNs> shifted = t;
    for (auto& s : shifted) s = s > INT64_MAX - 10'000'000 ? s : s + 10'000'000;
    std::sort(shifted.begin(), shifted.end());
    (void)kestrel::io::associate_by_time(t, shifted, 20'000'000);
  });
  return 0;
}
