// How sharp an image is: the variance of its Laplacian (Pech-Pacheco et al., "Diatom
// autofocusing in brightfield microscopy", ICPR 2000). Motion blur is a low-pass filter: it
// removes the fine detail the Laplacian responds to, so the ratio of two frames' values says
// how much more one is blurred than the other, whatever the scene's contrast.
#pragma once

#include <opencv2/core.hpp>

namespace kestrel::image {

/// Variance of the 4-neighbour Laplacian I(x-1,y) + I(x+1,y) + I(x,y-1) + I(x,y+1) - 4 I(x,y)
/// over the interior pixels of a CV_32FC1 image (at least 3x3), in intensity units squared.
/// One pass, no allocation.
[[nodiscard]] double laplacian_variance(const cv::Mat& image);

}  // namespace kestrel::image
