#include "sim/simulation_options.h"

#include <cmath>

namespace rs {
namespace {
constexpr const char* kStage = "simulate";
}

const OptionTable<SimulationOptions>& SimulationOptions::Table() {
  using O = SimulationOptions;
  static const auto table =
      OptionTable<O>()
          .Add("preset", &O::preset, "name of the preset these options started from (informational)")
          .Add("seed", &O::seed, "random seed for scene, texture, flight wobble and all noise")
          .Min(0)
          .Add("origin_lat_deg", &O::origin_lat_deg, "WGS84 latitude of the local ENU origin", "deg")
          .Min(-89)
          .Max(89)
          .Add("origin_lon_deg", &O::origin_lon_deg, "WGS84 longitude of the local ENU origin", "deg")
          .Min(-180)
          .Max(180)
          .Add("origin_h_m", &O::origin_h_m, "ellipsoidal height of the origin", "m")
          .Min(-500)
          .Max(9000)
          .Add("start_time_ns", &O::start_time_ns, "UTC time of the first frame, ns since the Unix epoch", "ns")
          .Min(0)
          .Add("road_length_m", &O::road_length_m, "centreline length", "m")
          .Min(10)
          .Max(5000)
          .Add("road_width_m", &O::road_width_m, "carriageway width between kerbs", "m")
          .Min(3)
          .Max(20)
          .Add("road_heading_deg", &O::road_heading_deg, "compass bearing of the road at its start", "deg")
          .Min(-360)
          .Max(360)
          .Add("road_curvature_1_m", &O::road_curvature_1_m, "signed centreline curvature, > 0 turns left", "1/m")
          .Min(-0.02)
          .Max(0.02)
          .Add("road_grade", &O::road_grade, "longitudinal slope (rise per metre)")
          .Min(-0.12)
          .Max(0.12)
          .Add("road_crossfall", &O::road_crossfall, "camber fall per metre from crown to kerb")
          .Min(0)
          .Max(0.08)
          .Add("kerb_height_m", &O::kerb_height_m, "kerb face height", "m")
          .Min(0)
          .Max(0.25)
          .Add("verge_width_m", &O::verge_width_m, "grass verge width beyond each kerb", "m")
          .Min(0)
          .Max(20)
          .Add("lane_markings", &O::lane_markings, "dashed centre line and solid edge lines")
          .Add("potholes_per_100m", &O::potholes_per_100m, "potholes per 100 m of flown road")
          .Min(0)
          .Max(200)
          .Add("cracks_per_100m", &O::cracks_per_100m, "longitudinal/transverse cracks per 100 m")
          .Min(0)
          .Max(200)
          .Add("alligator_per_100m", &O::alligator_per_100m, "alligator cracking areas per 100 m")
          .Min(0)
          .Max(100)
          .Add("patches_per_100m", &O::patches_per_100m, "repair patches per 100 m")
          .Min(0)
          .Max(100)
          .Add("damage_resolution_m", &O::damage_resolution_m, "heightfield cell size inside damage", "m")
          .Min(0.001)
          .Max(0.005)
          .Add("parked_cars", &O::parked_cars, "car-sized boxes parked at the kerb")
          .Min(0)
          .Max(50)
          .Add("people", &O::people, "person-sized cylinders on the road")
          .Min(0)
          .Max(50)
          .Add("sun_elevation_deg", &O::sun_elevation_deg, "sun elevation", "deg")
          .Min(5)
          .Max(90)
          .Add("sun_azimuth_deg", &O::sun_azimuth_deg, "sun compass bearing", "deg")
          .Min(-360)
          .Max(360)
          .Add("shadows", &O::shadows, "obstacles cast shadows")
          .Add("vignetting", &O::vignetting, "brightness loss at the image corner")
          .Min(0)
          .Max(0.9)
          .Add("right_gain", &O::right_gain, "right camera gain relative to the left")
          .Min(0.5)
          .Max(2)
          .Add("noise_sigma_dn", &O::noise_sigma_dn, "sensor noise, grey levels")
          .Min(0)
          .Max(30)
          .Add("motion_blur_samples", &O::motion_blur_samples, "sub-exposure renders per image")
          .Min(1)
          .Max(16)
          .Add("exposure_s", &O::exposure_s, "exposure time", "s")
          .Min(0)
          .Max(0.1)
          .Add("image_format", &O::image_format, "image file format")
          .OneOf({"png", "jpg"})
          .Add("jpeg_quality", &O::jpeg_quality, "JPEG quality")
          .Min(10)
          .Max(100)
          .Add("image_width", &O::image_width, "image width", "px")
          .Min(32)
          .Max(8192)
          .Add("image_height", &O::image_height, "image height", "px")
          .Min(32)
          .Max(8192)
          .Add("focal_px", &O::focal_px, "focal length", "px")
          .Min(10)
          .Max(50000)
          .Add("cx_px", &O::cx_px, "principal point x (< 0: centre)", "px")
          .Add("cy_px", &O::cy_px, "principal point y (< 0: centre)", "px")
          .Add("baseline_m", &O::baseline_m, "stereo baseline", "m")
          .Min(0.02)
          .Max(2)
          .Add("rectified", &O::rectified, "ideal rectified pair (false: raw with distortion)")
          .Add("k1", &O::k1, "radial distortion k1 (raw output)")
          .Min(-1)
          .Max(1)
          .Add("k2", &O::k2, "radial distortion k2 (raw output)")
          .Min(-1)
          .Max(1)
          .Add("p1", &O::p1, "tangential distortion p1 (raw output)")
          .Min(-0.1)
          .Max(0.1)
          .Add("p2", &O::p2, "tangential distortion p2 (raw output)")
          .Min(-0.1)
          .Max(0.1)
          .Add("raw_right_rotation_deg", &O::raw_right_rotation_deg, "right camera misalignment (raw output)", "deg")
          .Min(0)
          .Max(5)
          .Add("platform", &O::platform, "vehicle")
          .OneOf({"drone", "car"})
          .Add("altitude_m", &O::altitude_m, "camera height above the road", "m")
          .Min(0.5)
          .Max(200)
          .Add("camera_pitch_deg", &O::camera_pitch_deg, "optical axis below the horizon", "deg")
          .Min(5)
          .Max(90)
          .Add("speed_m_s", &O::speed_m_s, "ground speed", "m/s")
          .Min(0.1)
          .Max(40)
          .Add("frame_rate_hz", &O::frame_rate_hz, "stereo frame rate", "Hz")
          .Min(0.1)
          .Max(100)
          .Add("num_frames", &O::num_frames, "frames to render")
          .Min(1)
          .Max(100000)
          .Add("start_s_m", &O::start_s_m, "road distance of the first frame", "m")
          .Min(0)
          .Add("out_and_back", &O::out_and_back, "fly to the end, turn, fly back")
          .Add("turn_duration_s", &O::turn_duration_s, "turn time at the far end", "s")
          .Min(0)
          .Max(120)
          .Add("wobble_scale", &O::wobble_scale, "scale of the platform wobble")
          .Min(0)
          .Max(10)
          .Add("gnss_rate_hz", &O::gnss_rate_hz, "GNSS fix rate", "Hz")
          .Min(0.5)
          .Max(100)
          .Add("gnss_noise_m", &O::gnss_noise_m, "GNSS white noise, 1 sigma", "m")
          .Min(0)
          .Max(50)
          .Add("gnss_bias_m", &O::gnss_bias_m, "GNSS bias, 1 sigma", "m")
          .Min(0)
          .Max(50)
          .Add("gnss_bias_tau_s", &O::gnss_bias_tau_s, "GNSS bias correlation time", "s")
          .Above(0)
          .Add("gnss_rtk", &O::gnss_rtk, "label fixes RTK fixed")
          .Add("attitude_rate_hz", &O::attitude_rate_hz, "attitude sample rate", "Hz")
          .Min(1)
          .Max(1000)
          .Add("attitude_noise_deg", &O::attitude_noise_deg, "attitude noise per axis, 1 sigma", "deg")
          .Min(0)
          .Max(20)
          .Add("clock_offset_s", &O::clock_offset_s, "camera clock minus log clock", "s")
          .Min(-3600)
          .Max(3600)
          .Add("mesh_resolution_m", &O::mesh_resolution_m, "road_surface.ply grid spacing", "m")
          .Min(0.005)
          .Max(1);
  return table;
}

void SimulationOptions::Check() const {
  // Range rules live in the table; Merge() checks them for JSON input, this
  // checks a struct built in code the same way.
  const nlohmann::json j = Table().ToJson(*this);
  Table().Merge(j, kStage);

  CheckRule(road_curvature_1_m == 0 || std::abs(1 / road_curvature_1_m) > road_width_m / 2 + verge_width_m + 1, kStage,
            "road_curvature_1_m", road_curvature_1_m, "1/|road_curvature_1_m| > road_width_m/2 + verge_width_m + 1",
            "the road corridor must not cross the curve centre");
  CheckRule(std::abs(road_curvature_1_m) * road_length_m < 3.0, kStage, "road_curvature_1_m", road_curvature_1_m,
            "|road_curvature_1_m| * road_length_m < 3 rad", "the road may turn by less than ~170 degrees");
  CheckRule(cx_px < image_width && cy_px < image_height, kStage, "cx_px", cx_px,
            "cx_px < image_width and cy_px < image_height");
  const double flight_s = (num_frames - 1) / frame_rate_hz;
  if (!out_and_back) {
    const double end_s = start_s_m + speed_m_s * flight_s;
    CheckRule(
        end_s <= road_length_m - 2, kStage, "num_frames", num_frames,
        "start_s_m + speed_m_s * (num_frames - 1) / frame_rate_hz <= road_length_m - 2",
        "the flight would end at " + std::to_string(end_s) + " m on a " + std::to_string(road_length_m) + " m road");
  } else {
    const double turn_s = road_length_m - start_s_m;
    CheckRule(turn_s > start_s_m + 1, kStage, "start_s_m", start_s_m, "start_s_m < road_length_m / 2 for out_and_back");
    const double back_m = speed_m_s * (flight_s - (turn_s - start_s_m) / speed_m_s - turn_duration_s);
    CheckRule(back_m <= turn_s - 2, kStage, "num_frames", num_frames,
              "the return leg must end before the road start (s >= 2 m)");
  }
  CheckRule(platform != "car" || altitude_m <= 5, kStage, "altitude_m", altitude_m, "altitude_m <= 5 for platform car");
}

const std::vector<std::string>& PresetNames() {
  static const std::vector<std::string> names = {"demo", "drone-low", "drone-high", "car", "loop", "obstacles", "rtk", "straight"};
  return names;
}

SimulationOptions PresetOptions(const std::string& name) {
  SimulationOptions o;
  o.preset = name;
  if (name == "demo") {
    // Defaults: ~48 frames of a nadir drone at 6 m over 20 m of damaged road.
  } else if (name == "drone-low") {
    o.altitude_m = 4;
    o.speed_m_s = 3;
    o.frame_rate_hz = 15;
    o.num_frames = 150;
    o.road_length_m = 60;
  } else if (name == "drone-high") {
    // Pixels ~25 mm on the ground: the fine aggregate texture is gone, few keypoints survive.
    o.altitude_m = 25;
    o.speed_m_s = 6;
    o.frame_rate_hz = 10;
    o.num_frames = 100;
    o.road_length_m = 120;
    o.start_s_m = 25;
    o.wobble_scale = 1.5;
  } else if (name == "car") {
    o.platform = "car";
    o.altitude_m = 1.5;
    o.camera_pitch_deg = 15;
    o.speed_m_s = 8;
    o.frame_rate_hz = 15;
    o.num_frames = 150;
    o.road_length_m = 140;
    o.start_s_m = 5;
    o.parked_cars = 1;
  } else if (name == "loop") {
    o.road_length_m = 240;
    o.out_and_back = true;
    o.speed_m_s = 5;
    o.frame_rate_hz = 10;
    o.start_s_m = 15;
    o.num_frames = 870;
    o.potholes_per_100m = 8;
    o.cracks_per_100m = 6;
    o.alligator_per_100m = 2;
    o.patches_per_100m = 2;
  } else if (name == "obstacles") {
    o.parked_cars = 2;
    o.people = 1;
  } else if (name == "rtk") {
    o.gnss_noise_m = 0.012;
    o.gnss_bias_m = 0.008;
    o.gnss_rtk = true;
  } else if (name == "straight") {
    // A straight, level-across road: roll about the track is unobservable from GNSS positions.
    o.road_curvature_1_m = 0;
    o.road_length_m = 70;
    o.speed_m_s = 5;
    o.frame_rate_hz = 10;
    o.num_frames = 80;
  } else {
    std::string list;
    for (const auto& n : PresetNames()) list += (list.empty() ? "" : ", ") + n;
    throw OptionError("unknown simulate preset \"" + name + "\"; presets are: " + list);
  }
  return o;
}

}  // namespace rs
