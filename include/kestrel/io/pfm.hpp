// PFM (Portable Float Map), the format of Middlebury's disparity maps: a text header
// ("Pf" grey / "PF" colour, "W H", scale whose sign gives the byte order) and float32 rows from
// the BOTTOM row up. Middlebury marks "no disparity" as +inf.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <string_view>

namespace kestrel::io {

/// Reads a PFM file as CV_32FC1 ("Pf") or CV_32FC3 ("PF", BGR order as OpenCV keeps colour),
/// top row first. Throws InputError naming the file for a bad header or a short file.
cv::Mat read_pfm(const std::filesystem::path& path);

/// Writes CV_32FC1 or CV_32FC3 as little-endian PFM (scale -1), bottom row first. Refuses to
/// overwrite a file that is not a PFM unless `force` (PFM is binary: no provenance line).
void write_pfm(const std::filesystem::path& path, const cv::Mat& image, bool force = false);

}  // namespace kestrel::io
