// The Bayer-in-YUYV stereo decoder (`kestrel capture --decode-file`, the camera stage of
// `kestrel run`): the first bytes choose the options and row stride, the rest is the frame.
// Sizes are kept small (views up to 64x64) so that each input runs in microseconds.
#include "kestrel/driver/stereo_frame_decoder.hpp"

#include <span>

#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace kestrel::driver;
  if (size < 5) return 0;
  StereoDecoderOptions options;
  options.width = data[0] % 65;  // 0 and 1 are invalid: the constructor must refuse them
  options.height = data[1] % 65;
  options.left_byte = data[2] % 3;  // 2 is invalid
  options.phase = static_cast<BayerPhase>((data[3] >> 2) % 4);
  options.demosaic = (data[3] & 1) ? DemosaicMethod::kEdgeAware : DemosaicMethod::kBilinear;
  const ViewKind kind = static_cast<ViewKind>((data[3] >> 4) % 3);
  // Row stride: 0 (unpadded), or 2 * width plus up to 127 bytes of padding, or (bit 7) a
  // stride below 2 * width, which split() must refuse.
  std::size_t bytes_per_line = 0;
  if (data[4] != 0) {
    bytes_per_line = (data[4] & 0x80U) ? (data[4] & 0x7FU)
                                       : 2U * static_cast<std::size_t>(options.width) + data[4];
  }
  const std::span<const std::uint8_t> frame(data + 5, size - 5);
  kestrel::fuzz::expect_parsed_or_refused([&] {
    const StereoFrameDecoder decoder(options);
    StereoMosaic mosaic;
    const FrameHealth health = decoder.split(frame, bytes_per_line, mosaic);
    (void)health.describe();
    if (!health.ok()) return;
    // The first word's bytes are the two sensors' first samples, the last row's last word
    // their last ones.
    const std::size_t step = bytes_per_line ? bytes_per_line : options.packed_row_bytes();
    const std::size_t last =
        step * static_cast<std::size_t>(options.height - 1) + options.packed_row_bytes() - 2;
    const auto lb = static_cast<std::size_t>(options.left_byte);
    if (mosaic.left.at<std::uint8_t>(0, 0) != frame[lb] ||
        mosaic.right.at<std::uint8_t>(0, 0) != frame[1 - lb] ||
        mosaic.left.at<std::uint8_t>(options.height - 1, options.width - 1) != frame[last + lb] ||
        mosaic.right.at<std::uint8_t>(options.height - 1, options.width - 1) !=
            frame[last + 1 - lb]) {
      __builtin_trap();
    }
    cv::Mat view;
    decoder.convert(mosaic.left, kind, view);
    decoder.convert(mosaic.right, kind, view);
    if (view.empty()) __builtin_trap();  // a healthy frame must give a view
  });
  return 0;
}
