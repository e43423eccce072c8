// Camera models: round trips over pixel grids, analytic vs numeric Jacobians, OpenCV as an oracle for
// projection and undistortion, validation, and the stereo / RGB-D helpers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>

#include "fleetslam/core/camera.hpp"
#include "fleetslam/core/error.hpp"

namespace fleetslam::core {
namespace {

// TUM freiburg1 (Kinect): strong radial distortion with a k3 term.
PinholeCamera tum1_camera() {
  return PinholeCamera(640, 480, 517.306408, 516.469215, 318.643040, 255.313989,
                       Distortion{0.262383, -0.953104, -0.005358, 0.002628, 1.163314});
}

// EuRoC cam0: barrel distortion, no k3.
PinholeCamera euroc_camera() {
  return PinholeCamera(752, 480, 458.654, 457.296, 367.215, 248.375,
                       Distortion{-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0});
}

struct NamedCamera {
  const char* name;
  PinholeCamera camera;
};

std::vector<NamedCamera> test_cameras() {
  return {{"tum1", tum1_camera()}, {"euroc", euroc_camera()},
          {"ideal", PinholeCamera(320, 240, 300.0, 310.0, 160.5, 119.5)}};
}

// Every `step` pixels over the whole image, the last row and column included.
std::vector<Eigen::Vector2d> pixel_grid(const PinholeCamera& camera, int step) {
  std::vector<Eigen::Vector2d> grid;
  for (int v = 0;; v = std::min(v + step, camera.height() - 1)) {
    for (int u = 0;; u = std::min(u + step, camera.width() - 1)) {
      grid.emplace_back(u, v);
      if (u == camera.width() - 1) break;
    }
    if (v == camera.height() - 1) break;
  }
  return grid;
}

// Random camera-frame points that project inside the image, at depths from 0.3 to 20 m.
std::vector<Eigen::Vector3d> points_in_view(const PinholeCamera& camera, int count, unsigned seed) {
  std::mt19937 engine(seed);
  std::uniform_real_distribution<double> u(0.0, camera.width() - 1.0);
  std::uniform_real_distribution<double> v(0.0, camera.height() - 1.0);
  std::uniform_real_distribution<double> depth(0.3, 20.0);
  std::vector<Eigen::Vector3d> points;
  while (static_cast<int>(points.size()) < count) {
    const std::optional<Eigen::Vector3d> p = camera.unproject(Eigen::Vector2d(u(engine), v(engine)), depth(engine));
    if (p) points.push_back(*p);
  }
  return points;
}

cv::Matx33d cv_K(const PinholeCamera& camera) {
  return {camera.fx(), 0.0, camera.cx(), 0.0, camera.fy(), camera.cy(), 0.0, 0.0, 1.0};
}

cv::Matx<double, 5, 1> cv_D(const PinholeCamera& camera) {
  const Distortion& d = camera.distortion();
  return {d.k1, d.k2, d.p1, d.p2, d.k3};
}

TEST(Camera, UnprojectThenProjectIsIdentityOverThePixelGrid) {
  for (const NamedCamera& c : test_cameras()) {
    int checked = 0;
    for (const Eigen::Vector2d& uv : pixel_grid(c.camera, 8)) {
      const std::optional<Eigen::Vector3d> ray = c.camera.unproject(uv);
      ASSERT_TRUE(ray.has_value()) << c.name << " at " << uv.transpose();
      EXPECT_DOUBLE_EQ(ray->z(), 1.0);
      const std::optional<Eigen::Vector2d> back = c.camera.project(*ray);
      ASSERT_TRUE(back.has_value());
      EXPECT_LT((*back - uv).norm(), 1e-8) << c.name << " at " << uv.transpose();

      const std::optional<Eigen::Vector3d> p = c.camera.unproject(uv, 3.7);
      ASSERT_TRUE(p.has_value());
      EXPECT_DOUBLE_EQ(p->z(), 3.7);
      EXPECT_LT((*c.camera.project(*p) - uv).norm(), 1e-8) << c.name;
      ++checked;
    }
    EXPECT_GT(checked, 1000) << c.name;
  }
}

TEST(Camera, ProjectThenUnprojectGivesTheRay) {
  for (const NamedCamera& c : test_cameras()) {
    for (const Eigen::Vector3d& p : points_in_view(c.camera, 300, 21)) {
      const std::optional<Eigen::Vector3d> q = c.camera.unproject(*c.camera.project(p), p.z());
      ASSERT_TRUE(q.has_value());
      EXPECT_LT((*q - p).norm(), 1e-9 * p.norm()) << c.name;
    }
  }
}

TEST(Camera, ProjectMatchesOpenCvProjectPoints) {
  for (const NamedCamera& c : test_cameras()) {
    const std::vector<Eigen::Vector3d> points = points_in_view(c.camera, 200, 22);
    std::vector<cv::Point3d> object;
    for (const Eigen::Vector3d& p : points) object.emplace_back(p.x(), p.y(), p.z());
    std::vector<cv::Point2d> image;
    cv::projectPoints(object, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv_K(c.camera), cv_D(c.camera), image);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d uv = *c.camera.project(points[i]);
      EXPECT_NEAR(uv.x(), image[i].x, 1e-9) << c.name;
      EXPECT_NEAR(uv.y(), image[i].y, 1e-9) << c.name;
    }
  }
}

TEST(Camera, UndistortPointsMatchesOpenCv) {
  for (const NamedCamera& c : test_cameras()) {
    const std::vector<Eigen::Vector2d> grid = pixel_grid(c.camera, 16);
    std::vector<cv::Point2d> distorted;
    for (const Eigen::Vector2d& uv : grid) distorted.emplace_back(uv.x(), uv.y());
    std::vector<cv::Point2d> expected;
    // OpenCV's default stops after 5 fixed-point iterations; ask it to converge.
    cv::undistortPoints(distorted, expected, cv_K(c.camera), cv_D(c.camera), cv::noArray(), cv_K(c.camera),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 500, 1e-12));
    const std::vector<Eigen::Vector2d> ours = c.camera.undistort_points(grid);
    ASSERT_EQ(ours.size(), grid.size());
    for (std::size_t i = 0; i < grid.size(); ++i) {
      EXPECT_NEAR(ours[i].x(), expected[i].x, 1e-6) << c.name << " at " << grid[i].transpose();
      EXPECT_NEAR(ours[i].y(), expected[i].y, 1e-6) << c.name << " at " << grid[i].transpose();
    }
  }
}

TEST(Camera, UndistortPointsGivesPixelsOfTheUndistortedCamera) {
  const PinholeCamera camera = tum1_camera();
  const PinholeCamera ideal = camera.undistorted();
  EXPECT_TRUE(ideal.distortion().is_zero());
  for (const Eigen::Vector3d& p : points_in_view(camera, 100, 23)) {
    const std::vector<Eigen::Vector2d> undistorted = camera.undistort_points({*camera.project(p)});
    EXPECT_LT((undistorted[0] - *ideal.project(p)).norm(), 1e-8);
  }
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Eigen::Vector2d> bad = camera.undistort_points({Eigen::Vector2d(kNaN, 3.0)});
  EXPECT_TRUE(std::isnan(bad[0].x()) && std::isnan(bad[0].y()));
}

TEST(Camera, ProjectJacobianMatchesNumericDifferentiation) {
  for (const NamedCamera& c : test_cameras()) {
    for (const Eigen::Vector3d& p : points_in_view(c.camera, 200, 24)) {
      Eigen::Vector2d uv;
      Eigen::Matrix<double, 2, 3> J;
      ASSERT_TRUE(c.camera.project(p, &uv, &J));
      EXPECT_EQ(uv, *c.camera.project(p));
      Eigen::Matrix<double, 2, 3> numeric;
      const double h = 1e-6 * p.norm();
      for (int i = 0; i < 3; ++i) {
        const Eigen::Vector3d d = h * Eigen::Vector3d::Unit(i);
        numeric.col(i) = (*c.camera.project(p + d) - *c.camera.project(p - d)) / (2.0 * h);
      }
      EXPECT_LT((J - numeric).cwiseAbs().maxCoeff(), 1e-6 * (1.0 + J.cwiseAbs().maxCoeff())) << c.name;
    }
  }
}

TEST(Camera, DistortJacobianMatchesNumericDifferentiation) {
  std::mt19937 engine(25);
  std::uniform_real_distribution<double> coordinate(-0.7, 0.7);
  for (const NamedCamera& c : test_cameras()) {
    for (int i = 0; i < 300; ++i) {
      const Eigen::Vector2d xn(coordinate(engine), coordinate(engine));
      Eigen::Matrix2d J;
      const Eigen::Vector2d xd = c.camera.distort(xn, &J);
      EXPECT_EQ(xd, c.camera.distort(xn));
      Eigen::Matrix2d numeric;
      constexpr double h = 1e-7;
      for (int k = 0; k < 2; ++k) {
        const Eigen::Vector2d d = h * Eigen::Vector2d::Unit(k);
        numeric.col(k) = (c.camera.distort(xn + d) - c.camera.distort(xn - d)) / (2.0 * h);
      }
      EXPECT_LT((J - numeric).cwiseAbs().maxCoeff(), 1e-7) << c.name << " at " << xn.transpose();
    }
  }
}

TEST(Camera, UndistortNormalizedInvertsDistort) {
  std::mt19937 engine(26);
  std::uniform_real_distribution<double> coordinate(-0.6, 0.6);
  for (const NamedCamera& c : test_cameras()) {
    for (int i = 0; i < 300; ++i) {
      const Eigen::Vector2d xn(coordinate(engine), coordinate(engine) * 0.8);
      const std::optional<Eigen::Vector2d> back = c.camera.undistort_normalized(c.camera.distort(xn));
      ASSERT_TRUE(back.has_value()) << c.name << " at " << xn.transpose();
      EXPECT_LT((*back - xn).norm(), 1e-11) << c.name;
    }
  }
}

// A lens valid over the whole image (monotonic out to the corners) folds over far outside it: a point 70
// degrees off axis would land back inside the image. It does not project, and the image still does.
TEST(Camera, PointsWhereTheLensModelFoldsOverDoNotProject) {
  const PinholeCamera camera(640, 480, 300.0, 300.0, 320.0, 240.0, Distortion{-0.3, 0.1, 0.0, 0.0, -0.01});
  ASSERT_TRUE(camera.unproject(Eigen::Vector2d(639.0, 479.0)).has_value());  // valid out to the corners
  EXPECT_FALSE(camera.project(Eigen::Vector3d(2.7, 0.0, 1.0)).has_value());
  Eigen::Vector2d uv;
  EXPECT_FALSE(camera.project(Eigen::Vector3d(2.7, 0.0, 1.0), &uv, nullptr));
  for (const Eigen::Vector3d& p : points_in_view(camera, 200, 5)) EXPECT_TRUE(camera.project(p).has_value());
}

std::string invalid_argument_message(int width, int height, double fx, double fy, double cx, double cy, Distortion d);

// TUM-VI cam0 (equidistant, 512x512, about 190 degrees across).
PinholeCamera tumvi_camera() {
  return PinholeCamera(512, 512, 190.97847715128717, 190.9733070521226, 254.93170605935475, 256.8974428996504,
                       Distortion::equidistant(0.0034823894022493434, 0.0007150348452162257, -0.0020532361418706202,
                                               0.00020293673591811182));
}

cv::Vec4d cv_fisheye_D(const PinholeCamera& camera) {
  const Distortion& d = camera.distortion();
  return {d.k1, d.k2, d.k3, d.k4};
}

// Camera-frame points up to max_angle off the optical axis, 0.3 to 20 m away.
std::vector<Eigen::Vector3d> points_within_angle(double max_angle_rad, int count, unsigned seed) {
  std::mt19937 engine(seed);
  std::uniform_real_distribution<double> angle(0.0, max_angle_rad);
  std::uniform_real_distribution<double> azimuth(-3.14159, 3.14159);
  std::uniform_real_distribution<double> range(0.3, 20.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) {
    const double theta = angle(engine);
    const double phi = azimuth(engine);
    points.push_back(range(engine) *
                     Eigen::Vector3d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)));
  }
  return points;
}

TEST(Camera, EquidistantMatchesOpenCvFisheye) {
  const PinholeCamera camera = tumvi_camera();
  const std::vector<Eigen::Vector3d> points = points_within_angle(80.0 * 3.14159265358979 / 180.0, 300, 31);
  std::vector<cv::Point3d> object;
  for (const Eigen::Vector3d& p : points) object.emplace_back(p.x(), p.y(), p.z());
  std::vector<cv::Point2d> image;
  cv::fisheye::projectPoints(object, image, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv_K(camera), cv_fisheye_D(camera));
  std::vector<Eigen::Vector2d> pixels;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d uv = *camera.project(points[i]);
    EXPECT_NEAR(uv.x(), image[i].x, 1e-9);
    EXPECT_NEAR(uv.y(), image[i].y, 1e-9);
    pixels.push_back(uv);
  }
  // Back to the pinhole plane: cv::fisheye::undistortPoints with the same K as the new camera.
  std::vector<cv::Point2d> distorted(image.begin(), image.end());
  std::vector<cv::Point2d> expected;
  cv::fisheye::undistortPoints(distorted, expected, cv_K(camera), cv_fisheye_D(camera), cv::noArray(), cv_K(camera),
                               cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-14));
  const std::vector<Eigen::Vector2d> ours = camera.undistort_points(pixels);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d truth = *camera.undistorted().project(points[i]);
    EXPECT_LT((ours[i] - truth).norm(), 1e-6 * (1.0 + truth.norm())) << i;
    EXPECT_LT((ours[i] - Eigen::Vector2d(expected[i].x, expected[i].y)).norm(), 1e-5 * (1.0 + truth.norm())) << i;
  }
}

TEST(Camera, EquidistantJacobiansAndInverse) {
  const PinholeCamera camera = tumvi_camera();
  for (const Eigen::Vector3d& p : points_within_angle(85.0 * 3.14159265358979 / 180.0, 300, 32)) {
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 3> J;
    ASSERT_TRUE(camera.project(p, &uv, &J));
    Eigen::Matrix<double, 2, 3> numeric;
    const double h = 1e-6 * p.norm();
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d d = h * Eigen::Vector3d::Unit(i);
      numeric.col(i) = (*camera.project(p + d) - *camera.project(p - d)) / (2.0 * h);
    }
    EXPECT_LT((J - numeric).cwiseAbs().maxCoeff(), 1e-6 * (1.0 + J.cwiseAbs().maxCoeff()));
    const std::optional<Eigen::Vector3d> q = camera.unproject(uv, p.z());
    ASSERT_TRUE(q.has_value()) << p.transpose();
    EXPECT_LT((*q - p).norm(), 1e-8 * p.norm());
  }
  // At the centre the model is the identity to first order.
  Eigen::Matrix2d J0;
  EXPECT_EQ(camera.distort(Eigen::Vector2d::Zero(), &J0), Eigen::Vector2d::Zero());
  EXPECT_TRUE(J0.isIdentity());
}

TEST(Camera, EquidistantIsAFisheyeAndSeesNoFurtherThanNinetyDegrees) {
  const PinholeCamera plain(512, 512, 200.0, 200.0, 256.0, 256.0, Distortion::equidistant(0.0, 0.0, 0.0, 0.0));
  EXPECT_FALSE(plain.distortion().is_zero());  // r_d = theta, not tan(theta)
  const Eigen::Vector2d xd = plain.distort(Eigen::Vector2d(1.0, 0.0));
  EXPECT_NEAR(xd.x(), 3.14159265358979 / 4.0, 1e-15);
  // A pixel 95 degrees off the axis (r_d = 200 px * 1.658 rad) has no point on the z = 1 plane.
  EXPECT_FALSE(plain.unproject(Eigen::Vector2d(256.0 + 200.0 * 1.658, 256.0)).has_value());
  EXPECT_TRUE(plain.unproject(Eigen::Vector2d(256.0 + 200.0 * 1.5, 256.0)).has_value());
  Distortion tangential = Distortion::equidistant(0.01, 0.0, 0.0, 0.0);
  tangential.p1 = 0.001;
  EXPECT_NE(invalid_argument_message(512, 512, 200, 200, 256, 256, tangential).find("tangential"), std::string::npos);
  Distortion radtan_k4;
  radtan_k4.k4 = 0.1;
  EXPECT_NE(invalid_argument_message(512, 512, 200, 200, 256, 256, radtan_k4).find("k4"), std::string::npos);
  EXPECT_EQ(std::string(to_string(DistortionModel::kEquidistant)), "equidistant");
}

TEST(Camera, PointsBehindOrOnTheCameraPlaneDoNotProject) {
  const PinholeCamera camera = tum1_camera();
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.1, 0.2, -1.0), Eigen::Vector3d(0.0, 0.0, 0.0),
                                   Eigen::Vector3d(1.0, 1.0, PinholeCamera::min_depth),
                                   Eigen::Vector3d(0.0, 0.0, kNaN)}) {
    EXPECT_FALSE(camera.project(p).has_value()) << p.transpose();
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 3> J;
    EXPECT_FALSE(camera.project(p, &uv, &J));
  }
  EXPECT_TRUE(camera.project(Eigen::Vector3d(0.0, 0.0, 2.0 * PinholeCamera::min_depth)).has_value());
  // Depth must be positive when unprojecting with depth.
  EXPECT_FALSE(camera.unproject(Eigen::Vector2d(100, 100), 0.0).has_value());
  EXPECT_FALSE(camera.unproject(Eigen::Vector2d(100, 100), -1.0).has_value());
  EXPECT_FALSE(camera.unproject(Eigen::Vector2d(100, 100), kNaN).has_value());
}

std::string invalid_argument_message(int width, int height, double fx, double fy, double cx, double cy,
                                     Distortion d = {}) {
  try {
    PinholeCamera(width, height, fx, fy, cx, cy, d);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no error";
}

TEST(Camera, ConstructorRejectsNonsense) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  EXPECT_NE(invalid_argument_message(0, 480, 500, 500, 320, 240).find("size"), std::string::npos);
  EXPECT_NE(invalid_argument_message(640, -1, 500, 500, 320, 240).find("size"), std::string::npos);
  EXPECT_NE(invalid_argument_message(640, 480, 0, 500, 320, 240).find("fx"), std::string::npos);
  EXPECT_NE(invalid_argument_message(640, 480, -500, 500, 320, 240).find("fx"), std::string::npos);
  EXPECT_NE(invalid_argument_message(640, 480, 500, -1, 320, 240).find("fy"), std::string::npos);
  EXPECT_NE(invalid_argument_message(640, 480, kNaN, 500, 320, 240).find("fx"), std::string::npos);
  EXPECT_NE(invalid_argument_message(640, 480, 500, kInf, 320, 240).find("fy"), std::string::npos);
  EXPECT_NE(invalid_argument_message(640, 480, 500, 500, kInf, 240).find("cx"), std::string::npos);
  EXPECT_NE(invalid_argument_message(640, 480, 500, 500, 320, kNaN).find("cy"), std::string::npos);
  EXPECT_NE(invalid_argument_message(640, 480, 500, 500, 320, 240, Distortion{kNaN, 0, 0, 0, 0}).find("k1"),
            std::string::npos);
  EXPECT_NE(invalid_argument_message(640, 480, 500, 500, 320, 240, Distortion{0, 0, 0, 0, kInf}).find("k3"),
            std::string::npos);
  EXPECT_EQ(invalid_argument_message(640, 480, 500, 500, -10, 240), "no error");  // cx outside is legal
}

TEST(Camera, KMatrix) {
  const PinholeCamera camera = euroc_camera();
  const Eigen::Matrix3d K = camera.K();
  EXPECT_EQ(K(0, 0), camera.fx());
  EXPECT_EQ(K(1, 1), camera.fy());
  EXPECT_EQ(K(0, 2), camera.cx());
  EXPECT_EQ(K(1, 2), camera.cy());
  EXPECT_EQ(K(2, 2), 1.0);
  EXPECT_EQ(K(0, 1), 0.0);
}

TEST(Camera, ScaledFollowsThePixelCentreConvention) {
  const PinholeCamera camera = tum1_camera();
  const PinholeCamera half = camera.scaled(0.5);
  EXPECT_EQ(half.width(), 320);
  EXPECT_EQ(half.height(), 240);
  EXPECT_DOUBLE_EQ(half.fx(), camera.fx() * 0.5);
  EXPECT_DOUBLE_EQ(half.fy(), camera.fy() * 0.5);
  EXPECT_DOUBLE_EQ(half.cx(), (camera.cx() + 0.5) * 0.5 - 0.5);
  EXPECT_EQ(half.distortion().k1, camera.distortion().k1);
  // A point lands where cv::resize moves the image content: u' = (u + 0.5) r - 0.5.
  for (double s : {0.5, 1.0 / 1.2, 2.0}) {
    const PinholeCamera scaled = camera.scaled(s);
    const double rx = static_cast<double>(scaled.width()) / camera.width();
    const double ry = static_cast<double>(scaled.height()) / camera.height();
    for (const Eigen::Vector3d& p : points_in_view(camera, 50, 27)) {
      const Eigen::Vector2d uv = *camera.project(p);
      const Eigen::Vector2d uv_scaled = *scaled.project(p);
      EXPECT_NEAR(uv_scaled.x(), (uv.x() + 0.5) * rx - 0.5, 1e-9);
      EXPECT_NEAR(uv_scaled.y(), (uv.y() + 0.5) * ry - 0.5, 1e-9);
    }
  }
  EXPECT_EQ(camera.scaled(1.0 / 1.2).width(), 533);
  EXPECT_THROW(camera.scaled(0.0), std::invalid_argument);
  EXPECT_THROW(camera.scaled(-1.0), std::invalid_argument);
  EXPECT_THROW(camera.scaled(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  EXPECT_THROW(camera.scaled(1e-4), std::invalid_argument);  // empty image
}

TEST(Camera, InImageUsesPixelCentres) {
  const PinholeCamera camera(640, 480, 500, 500, 320, 240);
  EXPECT_TRUE(camera.in_image(Eigen::Vector2d(0, 0)));
  EXPECT_TRUE(camera.in_image(Eigen::Vector2d(-0.5, -0.5)));
  EXPECT_TRUE(camera.in_image(Eigen::Vector2d(639.4, 479.4)));
  EXPECT_FALSE(camera.in_image(Eigen::Vector2d(639.5, 100)));
  EXPECT_FALSE(camera.in_image(Eigen::Vector2d(-0.6, 100)));
  EXPECT_FALSE(camera.in_image(Eigen::Vector2d(100, 480)));
  EXPECT_TRUE(camera.in_image(Eigen::Vector2d(10, 10), 10.0));
  EXPECT_FALSE(camera.in_image(Eigen::Vector2d(9, 10), 10.0));
  EXPECT_FALSE(camera.in_image(Eigen::Vector2d(630, 10), 10.0));
  EXPECT_FALSE(camera.in_image(Eigen::Vector2d(std::numeric_limits<double>::quiet_NaN(), 10)));
}

TEST(StereoRig, DisparityDepthRoundTrip) {
  StereoRig rig;
  rig.camera = PinholeCamera(752, 480, 435.2, 435.2, 367.2, 252.2);
  rig.baseline_m = 0.110;
  EXPECT_DOUBLE_EQ(rig.bf(), 0.110 * 435.2);
  for (double depth_m : {0.2, 1.0, 3.3, 12.0, 80.0}) {
    const std::optional<double> disparity = rig.disparity_from_depth(depth_m);
    ASSERT_TRUE(disparity.has_value());
    EXPECT_NEAR(*rig.depth_from_disparity(*disparity), depth_m, 1e-12 * depth_m);
    EXPECT_NEAR(rig.right_u(400.0, depth_m), 400.0 - *disparity, 1e-12);
  }
  // A point seen by both rectified cameras: the disparity of its projections gives its depth back.
  const Eigen::Vector3d p_left(0.4, -0.2, 2.5);
  const Eigen::Vector3d p_right = p_left - Eigen::Vector3d(rig.baseline_m, 0.0, 0.0);
  const double disparity = rig.camera.project(p_left)->x() - rig.camera.project(p_right)->x();
  EXPECT_NEAR(*rig.depth_from_disparity(disparity), 2.5, 1e-12);
  EXPECT_FALSE(rig.depth_from_disparity(0.0).has_value());
  EXPECT_FALSE(rig.depth_from_disparity(-3.0).has_value());
  EXPECT_FALSE(rig.disparity_from_depth(0.0).has_value());
  EXPECT_FALSE(rig.disparity_from_depth(-1.0).has_value());

  StereoRig no_baseline;
  EXPECT_THROW(no_baseline.depth_from_disparity(1.0), InvariantError);
}

TEST(RgbdCamera, RawDepthToMetres) {
  RgbdCamera rgbd;
  rgbd.camera = tum1_camera();
  EXPECT_DOUBLE_EQ(rgbd.depth_m_from_raw(5000), 1.0);
  EXPECT_DOUBLE_EQ(rgbd.depth_m_from_raw(12345), 12345.0 / 5000.0);
  EXPECT_EQ(rgbd.depth_m_from_raw(0), 0.0);       // no measurement
  EXPECT_EQ(rgbd.depth_m_from_raw(250), 0.0);     // 0.05 m, closer than min_depth_m
  EXPECT_EQ(rgbd.depth_m_from_raw(65535), 0.0);   // 13.1 m, beyond max_depth_m
  EXPECT_DOUBLE_EQ(rgbd.depth_m_from_raw(500), 0.1);    // min_depth_m itself is kept
  EXPECT_DOUBLE_EQ(rgbd.depth_m_from_raw(50000), 10.0);  // and max_depth_m
  rgbd.depth_scale = 1000.0;  // millimetres
  EXPECT_DOUBLE_EQ(rgbd.depth_m_from_raw(1500), 1.5);
}

}  // namespace
}  // namespace fleetslam::core
