#pragma once
// Every parameter of `roadsurvey simulate`: scene, appearance, rig, flight and
// flight log. Plain struct with in-class defaults (the "demo" preset); presets
// are named bundles of overrides. Documented in docs/simulator.md.

#include <cstdint>
#include <string>
#include <vector>

#include "survey/options.h"

namespace rs {

/// Parameters of one simulated survey. Deterministic: the same options (and
/// build) give byte-identical output.
struct SimulationOptions {
  std::string preset = "demo";  ///< name of the preset these options started from (informational)
  int64_t seed = 1;             ///< random seed for scene, texture, flight wobble and all noise

  // --- geodetic origin and timing
  double origin_lat_deg = 46.0569;              ///< WGS84 latitude of the local ENU origin (road start)
  double origin_lon_deg = 14.5058;              ///< WGS84 longitude of the local ENU origin
  double origin_h_m = 300.0;                    ///< ellipsoidal height of the origin, m
  int64_t start_time_ns = 1700000000000000000;  ///< UTC time of the first frame, ns since the Unix epoch

  // --- road
  double road_length_m = 60.0;        ///< centreline length, m
  double road_width_m = 7.0;          ///< carriageway width between kerbs, m
  double road_heading_deg = 30.0;     ///< compass bearing of the road at its start, deg clockwise from north
  double road_curvature_1_m = 0.002;  ///< signed centreline curvature (1/radius), 1/m; > 0 turns left
  double road_grade = 0.02;           ///< longitudinal slope, rise per metre along the road
  double road_crossfall = 0.025;      ///< camber: fall per metre from the crown towards each kerb
  double kerb_height_m = 0.12;        ///< kerb face height above the carriageway edge, m
  double verge_width_m = 2.5;         ///< grass verge beyond each kerb, m
  bool lane_markings = true;          ///< dashed centre line and solid edge lines

  // --- damage (counts per 100 m of flown road, placed where the cameras see)
  double potholes_per_100m = 20;       ///< potholes (0.15-1.5 m across, 15-120 mm deep)
  double cracks_per_100m = 14;         ///< longitudinal and transverse cracks (2-25 mm wide)
  double alligator_per_100m = 4;       ///< alligator (fatigue) cracking areas
  double patches_per_100m = 4;         ///< repair patches
  double damage_resolution_m = 0.004;  ///< heightfield cell size inside damage, m (<= 0.005)

  // --- obstacles
  int parked_cars = 0;  ///< car-sized boxes parked at the kerb
  int people = 0;       ///< person-sized cylinders standing on the road

  // --- appearance
  double sun_elevation_deg = 50;     ///< sun elevation above the horizon, deg
  double sun_azimuth_deg = 135;      ///< sun compass bearing, deg clockwise from north
  bool shadows = true;               ///< obstacles cast shadows on the road
  double vignetting = 0.25;          ///< brightness loss at the image corner (0 = none)
  double right_gain = 1.04;          ///< right camera gain relative to the left
  double noise_sigma_dn = 1.5;       ///< sensor noise standard deviation, grey levels (0..255)
  int motion_blur_samples = 1;       ///< sub-exposure renders averaged per image (1 = no blur)
  double exposure_s = 0.004;         ///< exposure time over which motion blur integrates, s
  std::string image_format = "png";  ///< "png" or "jpg" (8-bit grey)
  int jpeg_quality = 92;             ///< JPEG quality when image_format is "jpg"

  // --- stereo rig
  int image_width = 1280;   ///< px
  int image_height = 720;   ///< px
  double focal_px = 1000;   ///< focal length of both cameras, px
  double cx_px = -1;        ///< principal point x, px (< 0: image centre)
  double cy_px = -1;        ///< principal point y, px (< 0: image centre)
  double baseline_m = 0.3;  ///< stereo baseline, m
  bool rectified = true;    ///< true: ideal rectified pair; false: raw images with distortion
  double k1 = -0.05, k2 = 0.01, p1 = 0.0005, p2 = -0.0003;  ///< lens distortion used when rectified = false
  double raw_right_rotation_deg = 0.3;  ///< rotation of the right camera about each axis when rectified = false

  // --- platform and flight
  std::string platform = "drone";  ///< "drone" or "car"
  double altitude_m = 6.0;         ///< camera height above the road surface, m
  double camera_pitch_deg = 90;    ///< optical axis angle below the horizon, deg (90 = nadir)
  double speed_m_s = 4.0;          ///< ground speed along the road, m/s
  double frame_rate_hz = 12;       ///< stereo frame rate, Hz
  int num_frames = 48;             ///< frames to render
  double start_s_m = 12;           ///< distance along the road of the first frame, m
  bool out_and_back = false;       ///< fly to the end, turn, fly back (loop closure)
  double turn_duration_s = 4;      ///< hover-and-turn time at the far end, s
  double wobble_scale = 1.0;       ///< multiplies the platform's lateral/height/attitude wobble

  // --- flight log
  double gnss_rate_hz = 10;         ///< GNSS fix rate, Hz
  double gnss_noise_m = 0.4;        ///< white horizontal position noise per fix, 1 sigma, m (vertical x1.5)
  double gnss_bias_m = 1.2;         ///< slowly varying horizontal bias (Gauss-Markov), 1 sigma, m (vertical x1.5)
  double gnss_bias_tau_s = 60;      ///< correlation time of the bias, s
  bool gnss_rtk = false;            ///< label fixes as RTK fixed (fix_type 6) instead of 3D (3)
  double attitude_rate_hz = 50;     ///< attitude sample rate, Hz
  double attitude_noise_deg = 0.3;  ///< attitude noise per axis, 1 sigma, deg
  double clock_offset_s = 0.0;      ///< camera clock minus flight-log clock, s

  // --- truth
  double mesh_resolution_m = 0.05;  ///< grid spacing of truth/road_surface.ply, m

  /// Throws rs::OptionError stating the violated rule.
  void Check() const;

  /// One registration per option (CLI flags, JSON, schema).
  static const OptionTable<SimulationOptions>& Table();
};

/// Names of the presets, in documentation order.
const std::vector<std::string>& PresetNames();

/// Options of a named preset: demo, drone-low, drone-high, car, loop, obstacles, rtk, straight.
/// Throws rs::OptionError listing the presets for an unknown name.
SimulationOptions PresetOptions(const std::string& name);

}  // namespace rs
