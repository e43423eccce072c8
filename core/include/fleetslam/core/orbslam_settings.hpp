#pragma once
// Reader and writer of camera settings files in the ORB-SLAM2/3 format, which users arriving from
// ORB-SLAM carry and which ORB-SLAM3 runs on.
// They are OpenCV FileStorage YAML ("%YAML:1.0" header, !!opencv-matrix tags), which yaml-cpp cannot
// parse, so they are read with cv::FileStorage.
//
// Two layouts are understood:
//  - old (ORB-SLAM2, ORB-SLAM3 before v1.0): Camera.fx/fy/cx/cy/k1/k2/p1/p2/k3, Camera.bf, ThDepth,
//    DepthMapFactor, Tbc (IMU);
//  - File.version: "1.0" (ORB-SLAM3 v1.0): Camera.type ("PinHole" or "Rectified"), Camera1.*, Camera2.*,
//    Stereo.b, Stereo.T_c1_c2, Stereo.ThDepth, RGBD.DepthMapFactor, IMU.T_b_c1.
// Both share Camera.width/height/fps/RGB, Camera.newWidth/newHeight, IMU.NoiseGyro/NoiseAcc/GyroWalk/
// AccWalk/Frequency and ORBextractor.*. Other keys (Viewer.*, System.*, ...) are ignored.
// Not supported (an InputError says so): the old layout's LEFT.*/RIGHT.* rectification matrices (such
// files describe raw images by the rectified camera; give the raw cameras in the File.version "1.0"
// layout, which is rectified with stereo_rectify.hpp), and a KannalaBrandt8 stereo pair without
// Camera2.* and Stereo.T_c1_c2.
//
// Frames: Stereo.T_c1_c2 is the pose of camera 2 in camera 1 (it maps camera-2 points into camera 1),
// i.e. T_cam0_cam1; IMU.T_b_c1 (and Tbc) is the pose of camera 1 in the IMU body frame, T_body_cam0.
//
// Precision: matrix entries are read from their decimal text at double precision whatever the dt tag
// says (ORB-SLAM3's files say "f"), and numbers are written with the shortest decimal that reads back
// as the same double, so read(write(s)) == s exactly (see write_orbslam_settings for what a file holds).

#include <filesystem>
#include <optional>

#include "fleetslam/core/sensor_rig.hpp"

namespace fleetslam::core {

// ORBextractor.* (defaults: ORB-SLAM's usual values, used when a key is absent).
struct OrbExtractorSettings {
  int num_features = 1000;    // ORBextractor.nFeatures
  double scale_factor = 1.2;  // ORBextractor.scaleFactor, > 1
  int num_levels = 8;         // ORBextractor.nLevels
  int ini_fast_threshold = 20;  // ORBextractor.iniThFAST
  int min_fast_threshold = 7;   // ORBextractor.minThFAST
};

struct OrbSlamSettings {
  // Mode, cameras as recorded, extrinsics, IMU noise, depth scale, bf, fps, colour order.
  // Stereo from two cameras: cam1 and T_cam0_cam1 from Camera2.* and Stereo.T_c1_c2, bf = |t| * cam0.fx
  // (ORB-SLAM3 uses |t| times the rectified focal length once it rectifies the pair: so does this
  // project's front end, from the rectified rig of stereo_rectify.hpp; this bf serves close_depth_m, in
  // raw fx units).
  // Rectified stereo (old Camera.bf, or v1.0 Camera.type "Rectified" with Stereo.b): cam1 = cam0 and
  // T_cam0_cam1 = translation (baseline, 0, 0). RGB-D: bf is the virtual baseline times fx.
  SensorRig rig;
  OrbExtractorSettings orb;
  // Close/far depth threshold in baselines (ThDepth, Stereo.ThDepth); required for stereo and RGB-D,
  // 0 when absent otherwise. In metres: th_depth * rig.bf / rig.cam0.fx() (see close_depth_m()).
  double th_depth = 0.0;
  // Camera.newWidth/newHeight: ORB-SLAM3 resizes images to this size before tracking; 0 when absent.
  // The rig keeps the recorded calibration; PinholeCamera::scaled gives the resized one.
  int new_width = 0;
  int new_height = 0;

  double close_depth_m() const { return rig.cam0.fx() > 0.0 ? th_depth * rig.bf / rig.cam0.fx() : 0.0; }
};

// Reads a settings file. With `mode` unset, the mode is inferred: DepthMapFactor (RGBD.DepthMapFactor)
// -> RGB-D; a second camera (Camera2.*), Stereo.b / Stereo.T_c1_c2, Camera.type "Rectified" or an old
// Camera.bf -> stereo; otherwise monocular. IMU keys (IMU.T_b_c1, Tbc, IMU.Noise*, ...) turn monocular
// and stereo into their inertial variants (RGB-D with an IMU stays kRgbd, with rig.imu filled).
// A given mode must find the keys it needs. Throws InputError "file:key: why" for a missing file,
// a malformed file, a missing required key, a value of the wrong type or out of range (e.g. a
// non-positive focal length), a matrix that is not 4x4 or not rigid (a rotation off orthonormal by
// more than 1e-3; closer ones are orthonormalised, except those already orthonormal to double
// rounding, which are kept as written).
OrbSlamSettings read_orbslam_settings(const std::filesystem::path& file,
                                      std::optional<SensorMode> mode = std::nullopt);

// Writes `s` as an ORB-SLAM3 v1.0 settings file (%YAML:1.0, File.version "1.0") that ORB-SLAM3 and
// read_orbslam_settings both accept, for every mode:
//  - all: Camera.type, Camera1.fx/fy/cx/cy (k1/k2/p1/p2/k3 unless the distortion is zero),
//    Camera.width/height/fps/RGB, Camera.newWidth/newHeight when set, ORBextractor.*, Viewer.* (ORB-SLAM3
//    requires them when its viewer runs), Stereo.ThDepth when th_depth > 0;
//  - stereo: Camera.type "Rectified" with Stereo.b when cam1 equals cam0 without distortion and
//    T_cam0_cam1 is a pure +x translation (ORB-SLAM3 then skips rectification), else Camera2.* and
//    Stereo.T_c1_c2. bf is not stored: readers derive it as |t| * fx;
//  - RGB-D: RGBD.DepthMapFactor and Stereo.b = bf / fx (chosen so that Stereo.b * fx gives bf back);
//  - inertial modes, and RGB-D with an IMU: IMU.T_b_c1 and IMU.NoiseGyro/NoiseAcc/GyroWalk/AccWalk/
//    Frequency. A monocular or stereo rig's IMU is not written (the file would read back as inertial).
// Reals are written in real form (ORB-SLAM3 checks the type); Camera.fps is an integer when whole
// (ORB-SLAM3 reads an integer, so give it a whole frame rate). Matrices are !!opencv-matrix with dt f, as
// ORB-SLAM3 reads them, and 17-digit entries for this reader.
// Throws InputError "file:key: why" when the settings cannot be written so that they read back: stereo
// without cam1 or with a cam1 of another size, stereo or RGB-D without a positive th_depth, RGB-D
// without a positive bf or depth scale, an inertial mode without IMU noise or T_body_cam0, IMU noise
// that is not positive; and naming the file when it cannot be written.
void write_orbslam_settings(const std::filesystem::path& file, const OrbSlamSettings& s);

}  // namespace fleetslam::core
