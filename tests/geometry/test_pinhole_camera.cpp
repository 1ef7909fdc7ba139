// PinholeCamera and RectifiedStereo (pinhole_camera.hpp): projection round trips with and
// without radial-tangential distortion (EuRoC cam0, TUM freiburg1 with k3), the iterative
// undistortion over the whole image, OpenCV's calib3d as an outside reference, pyramid
// scaling, validation, and the stereo relation Z = B f / d (thesis eq. 2.9).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry_checks.hpp"
#include "geometry_samples.hpp"
#include "kestrel/geometry/pinhole_camera.hpp"

namespace kestrel {
namespace {

using test::GeometrySampler;
using test::kSamples;
using test::near;

struct CameraCase {
  const char* name;
  PinholeIntrinsics k;
  RadTanDistortion d;
};

void PrintTo(const CameraCase& c, std::ostream* os) { *os << c.name; }

// EuRoC MAV cam0 (sensor.yaml of the dataset): WVGA, strong barrel distortion.
constexpr PinholeIntrinsics kEurocK{458.654, 457.296, 367.215, 248.375, 752, 480};
constexpr RadTanDistortion kEurocD{-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0};
// TUM RGB-D freiburg1 (the benchmark's documentation), with k3.
constexpr PinholeIntrinsics kTumFr1K{517.3, 516.5, 318.6, 255.3, 640, 480};
constexpr RadTanDistortion kTumFr1D{0.2624, -0.9531, -0.0054, 0.0026, 1.1633};

const CameraCase kCameras[] = {
    {"euroc_undistorted", kEurocK, {}},
    {"euroc", kEurocK, kEurocD},
    {"tum_fr1", kTumFr1K, kTumFr1D},
};

// Pixel error allowed in a round trip: undistort() stops at a step of 1e-12 in normalised
// coordinates, i.e. ~5e-10 px; the rest is rounding at |u| ~ 1e3 (~1e-13 px).
constexpr double kPixelTol = 1e-9;

class Cameras : public ::testing::TestWithParam<CameraCase> {
 protected:
  PinholeCamera camera() const { return PinholeCamera(GetParam().k, GetParam().d); }
};
std::string camera_name(const ::testing::TestParamInfo<CameraCase>& param) {
  return param.param.name;
}
INSTANTIATE_TEST_SUITE_P(Calibrations, Cameras, ::testing::ValuesIn(kCameras), camera_name);

/// A pixel anywhere on the image, out to the outer edges of the border pixels.
Eigen::Vector2d random_pixel(GeometrySampler& rng, const PinholeCamera& cam) {
  return {rng.uniform(-0.5, cam.width() - 0.5), rng.uniform(-0.5, cam.height() - 0.5)};
}

/// A grid of every `step`-th pixel in u and v, every pixel of the image's border (where the
/// distortion is strongest) and the outer corners of the corner pixels, as distorted
/// normalised coordinates.
std::vector<Eigen::Vector2d> image_grid(const PinholeCamera& cam, int step) {
  const int w = cam.width(), h = cam.height();
  std::vector<Eigen::Vector2d> out;
  for (int v = step; v < h - 1; v += step)
    for (int u = step; u < w - 1; u += step) out.emplace_back(u, v);
  for (int u = 0; u < w; ++u) {
    out.emplace_back(u, 0);
    out.emplace_back(u, h - 1);
  }
  for (int v = 1; v < h - 1; ++v) {
    out.emplace_back(0, v);
    out.emplace_back(w - 1, v);
  }
  for (const double u : {-0.5, w - 0.5})
    for (const double v : {-0.5, h - 0.5}) out.emplace_back(u, v);
  for (auto& uv : out) uv = {(uv.x() - cam.cx()) / cam.fx(), (uv.y() - cam.cy()) / cam.fy()};
  return out;
}

TEST(PinholeCamera, RejectsInvalidIntrinsics) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  auto make = [](PinholeIntrinsics k, RadTanDistortion d = {}) { return PinholeCamera(k, d); };
  PinholeIntrinsics k = kEurocK;
  EXPECT_NO_THROW(make(k, kEurocD));
  for (const double bad : {0.0, -458.0, nan, inf}) {
    k = kEurocK;
    k.fx = bad;
    EXPECT_THROW(make(k), std::invalid_argument) << "fx " << bad;
    k = kEurocK;
    k.fy = bad;
    EXPECT_THROW(make(k), std::invalid_argument) << "fy " << bad;
  }
  for (const double bad : {nan, inf, -inf}) {
    k = kEurocK;
    k.cx = bad;
    EXPECT_THROW(make(k), std::invalid_argument) << "cx " << bad;
    k = kEurocK;
    k.cy = bad;
    EXPECT_THROW(make(k), std::invalid_argument) << "cy " << bad;
    for (double RadTanDistortion::*c :
         {&RadTanDistortion::k1, &RadTanDistortion::k2, &RadTanDistortion::p1,
          &RadTanDistortion::p2, &RadTanDistortion::k3}) {
      RadTanDistortion d = kEurocD;
      d.*c = bad;
      EXPECT_THROW(make(kEurocK, d), std::invalid_argument) << "distortion " << bad;
    }
  }
  for (const int bad : {0, -480}) {
    k = kEurocK;
    k.width = bad;
    EXPECT_THROW(make(k), std::invalid_argument) << "width " << bad;
    k = kEurocK;
    k.height = bad;
    EXPECT_THROW(make(k), std::invalid_argument) << "height " << bad;
  }
  // A principal point outside the image is unusual but valid (a crop).
  k = kEurocK;
  k.cx = -10.0;
  EXPECT_NO_THROW(make(k));
}

TEST(PinholeCamera, AccessorsAndCalibrationMatrix) {
  const PinholeCamera cam(kEurocK, kEurocD);
  EXPECT_EQ(cam.fx(), 458.654);
  EXPECT_EQ(cam.fy(), 457.296);
  EXPECT_EQ(cam.cx(), 367.215);
  EXPECT_EQ(cam.cy(), 248.375);
  EXPECT_EQ(cam.width(), 752);
  EXPECT_EQ(cam.height(), 480);
  EXPECT_TRUE(cam.has_distortion());
  EXPECT_EQ(cam.distortion().k2, kEurocD.k2);
  EXPECT_EQ(cam.intrinsics().cy, kEurocK.cy);
  Eigen::Matrix3d K;
  K << 458.654, 0, 367.215, 0, 457.296, 248.375, 0, 0, 1;
  EXPECT_TRUE(near(cam.K(), K, 0.0));
  EXPECT_FALSE(cam.without_distortion().has_distortion());
  EXPECT_TRUE(near(cam.without_distortion().K(), K, 0.0));
  EXPECT_NE(cam.describe().find("752x480"), std::string::npos) << cam.describe();
  EXPECT_NE(cam.describe().find("radtan"), std::string::npos) << cam.describe();
  EXPECT_EQ(cam.without_distortion().describe().find("radtan"), std::string::npos);
}

TEST(PinholeCamera, ProjectsThroughTheCalibrationMatrix) {
  // Without distortion, u = fx x/z + cx exactly: (K p) / z.
  const PinholeCamera cam(kTumFr1K);
  GeometrySampler rng(41);
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Vector3d p(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(0.1, 10));
    ASSERT_TRUE(near(cam.project(p), (cam.K() * p).hnormalized(), 1e-12)) << "sample " << i;
  }
  EXPECT_TRUE(near(cam.project({0, 0, 1}), Eigen::Vector2d(318.6, 255.3), 0.0));
}

TEST_P(Cameras, UnprojectThenProjectReturnsThePixel) {
  const PinholeCamera cam = camera();
  GeometrySampler rng(42);
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Vector2d uv = random_pixel(rng, cam);
    const double depth_m = std::exp(rng.uniform(std::log(0.1), std::log(20.0)));
    const Eigen::Vector3d p = cam.unproject(uv, depth_m);
    ASSERT_EQ(p.z(), depth_m);
    ASSERT_TRUE(near(cam.project(p), uv, kPixelTol)) << "sample " << i << " uv " << uv.transpose();
  }
}

TEST_P(Cameras, ProjectThenUnprojectReturnsThePoint) {
  const PinholeCamera cam = camera();
  GeometrySampler rng(43);
  int in_view = 0;
  while (in_view < kSamples) {
    const double z = rng.uniform(0.2, 20.0);
    const Eigen::Vector3d p(rng.uniform(-1.0, 1.0) * z, rng.uniform(-0.7, 0.7) * z, z);
    const Eigen::Vector2d uv = cam.project(p);
    if (uv.x() < -0.5 || uv.y() < -0.5 || uv.x() > cam.width() - 0.5 ||
        uv.y() > cam.height() - 0.5) {
      continue;  // outside the image, where a real lens' model need not be invertible
    }
    ++in_view;
    ASSERT_TRUE(near(cam.unproject(uv, z), p, 1e-10 * z)) << "p " << p.transpose();
  }
}

TEST_P(Cameras, UndistortInvertsDistortOverTheWholeImage) {
  const PinholeCamera cam = camera();
  for (const Eigen::Vector2d& xd : image_grid(cam, 6)) {
    const Eigen::Vector2d xn = cam.undistort(xd);
    ASSERT_TRUE(near(cam.distort(xn), xd, 1e-10)) << "xd " << xd.transpose();
    // And the other way: the ray of that pixel distorts and undistorts back to itself.
    ASSERT_TRUE(near(cam.undistort(cam.distort(xn)), xn, 1e-10)) << "xd " << xd.transpose();
  }
}

TEST(PinholeCamera, DistortionMatchesTheRadTanModel) {
  // x' = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2), y' likewise,
  // written out here independently of the implementation's Horner form.
  const PinholeCamera cam(kTumFr1K, kTumFr1D);
  const RadTanDistortion& d = kTumFr1D;
  GeometrySampler rng(44);
  for (int i = 0; i < kSamples; ++i) {
    const double x = rng.uniform(-0.7, 0.7), y = rng.uniform(-0.6, 0.6);
    const double r2 = x * x + y * y;
    const double radial = 1 + d.k1 * r2 + d.k2 * r2 * r2 + d.k3 * r2 * r2 * r2;
    const Eigen::Vector2d expected(x * radial + 2 * d.p1 * x * y + d.p2 * (r2 + 2 * x * x),
                                   y * radial + d.p1 * (r2 + 2 * y * y) + 2 * d.p2 * x * y);
    ASSERT_TRUE(near(cam.distort({x, y}), expected, 1e-15)) << "sample " << i;
  }
  // The principal point is a fixed point of the model.
  EXPECT_TRUE(near(cam.distort({0, 0}), Eigen::Vector2d::Zero(), 0.0));
  EXPECT_TRUE(near(cam.undistort({0, 0}), Eigen::Vector2d::Zero(), 0.0));
}

TEST_P(Cameras, ProjectMatchesOpenCv) {
  const PinholeCamera cam = camera();
  const CameraCase& c = GetParam();
  const cv::Matx33d K(c.k.fx, 0, c.k.cx, 0, c.k.fy, c.k.cy, 0, 0, 1);
  const std::vector<double> dist{c.d.k1, c.d.k2, c.d.p1, c.d.p2, c.d.k3};
  GeometrySampler rng(45);
  std::vector<cv::Point3d> points;
  for (int i = 0; i < kSamples; ++i) {
    const double z = rng.uniform(0.2, 20.0);
    points.emplace_back(rng.uniform(-0.8, 0.8) * z, rng.uniform(-0.5, 0.5) * z, z);
  }
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(points, cv::Vec3d::zeros(), cv::Vec3d::zeros(), K, dist, pixels);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d uv = cam.project({points[i].x, points[i].y, points[i].z});
    ASSERT_TRUE(near(uv, Eigen::Vector2d(pixels[i].x, pixels[i].y), 1e-9)) << "point " << i;
  }
}

TEST_P(Cameras, UndistortPixelMatchesOpenCv) {
  // cv::undistortPoints iterates a fixed point, not Newton, 5 times by default (0.6 px off
  // at EuRoC's corners, 0.1 px on TUM fr1); given 200 it converges on these lenses and
  // agrees with ours to ~1e-12 px.
  const PinholeCamera cam = camera();
  const CameraCase& c = GetParam();
  const cv::Matx33d K(c.k.fx, 0, c.k.cx, 0, c.k.fy, c.k.cy, 0, 0, 1);
  const std::vector<double> dist{c.d.k1, c.d.k2, c.d.p1, c.d.p2, c.d.k3};
  std::vector<cv::Point2d> distorted;
  for (const Eigen::Vector2d& xd : image_grid(cam, 8)) {
    distorted.emplace_back(xd.x() * c.k.fx + c.k.cx, xd.y() * c.k.fy + c.k.cy);
  }
  std::vector<cv::Point2d> undistorted;
  cv::undistortPoints(distorted, undistorted, K, dist, cv::noArray(), K,
                      cv::TermCriteria(cv::TermCriteria::COUNT, 200, 0.0));
  double worst = 0.0;
  for (std::size_t i = 0; i < distorted.size(); ++i) {
    const Eigen::Vector2d ours = cam.undistort_pixel({distorted[i].x, distorted[i].y});
    worst = std::max(worst, (ours - Eigen::Vector2d(undistorted[i].x, undistorted[i].y)).norm());
  }
  EXPECT_LT(worst, kPixelTol) << "px";
}

TEST_P(Cameras, UndistortPixelIsTheUndistortedCamerasProjection) {
  const PinholeCamera cam = camera();
  const PinholeCamera ideal = cam.without_distortion();
  GeometrySampler rng(46);
  for (int i = 0; i < kSamples; ++i) {
    const Eigen::Vector2d uv = random_pixel(rng, cam);
    const Eigen::Vector3d p = cam.unproject(uv, 2.0);
    ASSERT_TRUE(near(cam.undistort_pixel(uv), ideal.project(p), kPixelTol)) << "sample " << i;
  }
}

TEST_P(Cameras, ScaledCameraSeesPixelsAtScaledCoordinates) {
  // Pyramid level l has s = 2^-l; pixel centres sit at integers, pixel edges at half
  // integers, so a point seen at u in the full image is at (u + 0.5) s - 0.5.
  const PinholeCamera cam = camera();
  GeometrySampler rng(47);
  for (const double s : {0.5, 0.25, 0.125, 2.0}) {
    const PinholeCamera small = cam.scaled(s);
    EXPECT_DOUBLE_EQ(small.fx(), cam.fx() * s);
    EXPECT_DOUBLE_EQ(small.fy(), cam.fy() * s);
    EXPECT_DOUBLE_EQ(small.cx(), (cam.cx() + 0.5) * s - 0.5);
    EXPECT_DOUBLE_EQ(small.cy(), (cam.cy() + 0.5) * s - 0.5);
    EXPECT_EQ(small.width(), static_cast<int>(cam.width() * s));
    EXPECT_EQ(small.height(), static_cast<int>(cam.height() * s));
    EXPECT_EQ(small.has_distortion(), cam.has_distortion());
    for (int i = 0; i < kSamples / 4; ++i) {
      const Eigen::Vector3d p = cam.unproject(random_pixel(rng, cam), rng.uniform(0.5, 5.0));
      const Eigen::Vector2d uv = cam.project(p);
      ASSERT_TRUE(near(small.project(p), ((uv.array() + 0.5) * s - 0.5).matrix(), 1e-9))
          << "s " << s << " sample " << i;
      ASSERT_TRUE(near(small.unproject(small.project(p), p.z()), p, 1e-9)) << "s " << s;
    }
  }
  // Halving three times is one scaling by 1/8 (the pyramid builds levels one by one); the
  // image edges stay at -0.5 and size - 0.5.
  const PinholeCamera level3 = cam.scaled(0.5).scaled(0.5).scaled(0.5);
  EXPECT_TRUE(near(level3.K(), cam.scaled(0.125).K(), 1e-12));
  EXPECT_EQ(level3.width(), cam.width() / 8);
  EXPECT_EQ(level3.height(), cam.height() / 8);
  EXPECT_THROW((void)cam.scaled(0.0), std::invalid_argument);
  EXPECT_THROW((void)cam.scaled(-0.5), std::invalid_argument);
}

TEST(PinholeCamera, PyramidSizesOfTheTwoSensors) {
  // WVGA 752x480 (the MT9V024) and VGA 640x480 (Kinect, and the thesis in places).
  const PinholeCamera wvga(kEurocK), vga(kTumFr1K);
  EXPECT_EQ(wvga.scaled(0.5).width(), 376);
  EXPECT_EQ(wvga.scaled(0.25).width(), 188);
  EXPECT_EQ(wvga.scaled(0.125).width(), 94);
  EXPECT_EQ(wvga.scaled(0.125).height(), 60);
  EXPECT_EQ(vga.scaled(0.125).width(), 80);
  EXPECT_EQ(vga.scaled(0.125).height(), 60);
}

// ---- Rectified stereo (thesis 2.4, eq. 2.9).

RectifiedStereo euroc_like_rig() {
  RectifiedStereo rig;
  rig.f = 458.654;
  rig.cu = 367.215;
  rig.cv = 248.375;
  rig.baseline_m = 0.110;
  rig.width = 752;
  rig.height = 480;
  return rig;
}

TEST(RectifiedStereo, DepthIsBaselineTimesFocalOverDisparity) {
  const RectifiedStereo rig = euroc_like_rig();
  EXPECT_NO_THROW(rig.validate());
  // 0.110 m * 458.654 px / 10 px = 5.045194 m.
  EXPECT_NEAR(rig.depth_from_disparity(10.0), 5.045194, 1e-12);
  EXPECT_NEAR(rig.disparity_from_depth(5.045194), 10.0, 1e-12);
  EXPECT_NEAR(rig.depth_from_disparity(rig.f * rig.baseline_m), 1.0, 1e-15);
  GeometrySampler rng(48);
  for (int i = 0; i < kSamples; ++i) {
    const double d = rng.uniform(0.5, 128.0);
    const double z = rig.depth_from_disparity(d);
    ASSERT_NEAR(z * d, rig.baseline_m * rig.f, 1e-12);
    ASSERT_NEAR(rig.disparity_from_depth(z), d, 1e-12 * d) << "sample " << i;
  }
}

TEST(RectifiedStereo, DisparityIsTheShiftBetweenTheTwoViews) {
  // The right camera sits B along +x of the left: p_right = p_left - (B, 0, 0). Its image
  // of a point is the left one shifted by d = uL - uR = B f / Z, on the same row.
  const RectifiedStereo rig = euroc_like_rig();
  const PinholeCamera left = rig.left();
  EXPECT_FALSE(left.has_distortion());
  EXPECT_EQ(left.fx(), rig.f);
  EXPECT_EQ(left.fy(), rig.f);
  EXPECT_EQ(left.cx(), rig.cu);
  EXPECT_EQ(left.cy(), rig.cv);
  EXPECT_EQ(left.width(), rig.width);
  EXPECT_EQ(left.height(), rig.height);
  GeometrySampler rng(49);
  for (int i = 0; i < kSamples; ++i) {
    const double z = rng.uniform(0.3, 30.0);
    const Eigen::Vector3d p_left = left.unproject(random_pixel(rng, left), z);
    const Eigen::Vector2d uv_left = left.project(p_left);
    const Eigen::Vector2d uv_right = left.project(p_left - Eigen::Vector3d(rig.baseline_m, 0, 0));
    ASSERT_NEAR(uv_left.y(), uv_right.y(), 1e-12);
    const double d = uv_left.x() - uv_right.x();
    ASSERT_NEAR(d, rig.disparity_from_depth(z), 1e-9) << "sample " << i;
    ASSERT_NEAR(rig.depth_from_disparity(d), z, 1e-9 * z * z) << "sample " << i;
  }
}

TEST(RectifiedStereo, ValidateRejectsDegenerateRigs) {
  const RectifiedStereo good = euroc_like_rig();
  auto with = [&](auto field, auto value) {
    RectifiedStereo r = good;
    r.*field = value;
    return r;
  };
  EXPECT_THROW(with(&RectifiedStereo::f, 0.0).validate(), std::invalid_argument);
  EXPECT_THROW(with(&RectifiedStereo::f, -1.0).validate(), std::invalid_argument);
  EXPECT_THROW(with(&RectifiedStereo::f, std::numeric_limits<double>::quiet_NaN()).validate(),
               std::invalid_argument);
  EXPECT_THROW(with(&RectifiedStereo::f, std::numeric_limits<double>::infinity()).validate(),
               std::invalid_argument);
  EXPECT_THROW(with(&RectifiedStereo::cu, std::numeric_limits<double>::quiet_NaN()).validate(),
               std::invalid_argument);
  EXPECT_THROW(with(&RectifiedStereo::cv, std::numeric_limits<double>::infinity()).validate(),
               std::invalid_argument);
  EXPECT_THROW(with(&RectifiedStereo::baseline_m, 0.0).validate(), std::invalid_argument);
  EXPECT_THROW(with(&RectifiedStereo::baseline_m, -0.11).validate(), std::invalid_argument);
  EXPECT_THROW(with(&RectifiedStereo::width, 0).validate(), std::invalid_argument);
  EXPECT_THROW(with(&RectifiedStereo::height, -1).validate(), std::invalid_argument);
  EXPECT_THROW((void)RectifiedStereo{}.left(), std::invalid_argument);
}

TEST(RectifiedStereo, CentredPutsThePrincipalPointAtTheImageCentre) {
  const RectifiedStereo rig = RectifiedStereo::centred(640, 481, 420.0, 0.12);
  EXPECT_EQ(rig.width, 640);
  EXPECT_EQ(rig.height, 481);
  EXPECT_EQ(rig.f, 420.0);
  EXPECT_EQ(rig.baseline_m, 0.12);
  EXPECT_EQ(rig.cu, 319.5);  // pixel centres 0 .. 639
  EXPECT_EQ(rig.cv, 240.0);
  EXPECT_NO_THROW(rig.validate());
}

}  // namespace
}  // namespace kestrel
