#include <gtest/gtest.h>
#include "kestrel/geometry/se3.hpp"
TEST(Smoke, ExpLog) {
  kestrel::Vector6d xi; xi << 0.1, -0.2, 0.3, 0.4, -0.5, 0.6;
  EXPECT_LT((kestrel::SE3::exp(xi).log() - xi).norm(), 1e-12);
}
