// disparity_bench: our GPT-SGM and SGM vs OpenCV StereoSGBM (SGBM, SGBM_3WAY) on the same
// pairs in one process. Usage: disparity_bench [--data DIR] [--reps N] [--no-middlebury]
// [--paths 4|8] [--gpt-range N] [--threads N] [--only gpt-sgm|sgm|sgbm|sgbm-3way]
// or: disparity_bench --fan2021 MODEL3_DIR [--out DIR] [--scale S] (real road pairs at full size, or resized by S, -> PNG previews)
// or: disparity_bench --sim SURVEY_DIR [--sim SURVEY_DIR ...] [--sim-step N] [--sim-frames N]
//     [--sim-bands] (simulated surveys: road D1 and pothole MAE beside StereoSGBM; with --sim-bands
//     GPT-SGM's road error by row band, docs/stages/disparity.md)
// or: disparity_bench --euroc MAV0_DIR [--out DIR] (EuRoC ASL layout, rectified here -> previews,
//     floor density)
// Any run: --set NAME=JSON_VALUE sets a stage option (names as in `roadsurvey stages disparity`).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <map>
#include <string>
#include <vector>

#include <memory>

#include <opencv2/core/utility.hpp>
#include <tbb/global_control.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "eval/disparity/disparity_benchmark.h"
#include "formats/disparity/disparity_io.h"
#include "stages/disparity/disparity_stage.h"
#include "eval/disparity/sim_disparity_eval.h"
#include "formats/stereo/calibration_readers.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/stereo/rectifier.h"

#include <filesystem>

#include <nlohmann/json.hpp>

namespace {

// Real road pairs (pothole_recon_fan2021/model3): GPT-SGM per pair, road model and density
// printed, colour-mapped disparity and transformed disparity written under out_dir.
// At full size (scale 1) the stage's defaults run as they are, with the focal length of the data's
// calibration_rectified.yaml (as `roadsurvey stereo --calibration` does); resized copies keep the
// earlier half-size settings.
int RunFan2021(const std::string& dir, const std::string& out_dir, double scale, rs::DisparityParams params) {
  if (scale != 1) {
    params.num_disparities = 256;  // fallback range at the working scale
    // A rig ~0.7 m above the road: potholes reach ~15 px below the road at half size.
    params.gpt_delta_px = 20, params.gpt_num_disparities = 48;
  }
  params.camera_focal_px = scale * rs::ReadCalibrationYaml(dir + "/calibration_rectified.yaml").left.fx;
  std::printf(
      "| pair | size | road model a0, a1, roll | tilt | matches / inliers | RMS px | reliable | disparities | valid "
      "density (all) | valid density (road visible in right view) | ms |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (int i = 1; i <= 5; ++i) {
    const std::string lp = dir + "/left images/L" + std::to_string(i) + ".png";
    const std::string rp = dir + "/right images/R" + std::to_string(i) + ".png";
    cv::Mat l = cv::imread(lp, cv::IMREAD_GRAYSCALE), r = cv::imread(rp, cv::IMREAD_GRAYSCALE);
    if (l.empty() || r.empty()) {
      std::fprintf(stderr, "cannot read %s or %s\n", lp.c_str(), rp.c_str());
      return 1;
    }
    if (scale != 1) {
      cv::resize(l, l, cv::Size(), scale, scale, cv::INTER_AREA);
      cv::resize(r, r, cv::Size(), scale, scale, cv::INTER_AREA);
    }
    const rs::DisparityResult res = rs::ComputeDisparity(l, r, params);
    const rs::RoadModel& m = res.road;
    int64_t visible = 0, visible_valid = 0;  // pixels whose road point lies inside the right image
    for (int v = 0; v < l.rows; ++v)
      for (int u = 0; u < l.cols; ++u)
        if (u - m.At(u, v) >= 0) ++visible, visible_valid += res.valid.at<uint8_t>(v, u) != 0;
    std::printf("| L%d/R%d | %dx%d | %.2f, %.4f, %.2f deg | %.2f deg | %d / %d | %.2f | %s | %d%s | %.1f %% | %.2f %% | "
                "%.0f |\n",
                i, i, l.cols, l.rows, m.a0, m.a1, m.roll_rad * 180 / M_PI, res.road_tilt_rad * 180 / M_PI,
                m.num_matches, m.num_inliers,
                m.residual_rms_px, m.reliable ? "yes" : "no", res.num_disparities, res.fell_back ? " (fell back)" : "",
                100 * res.valid_fraction, 100.0 * visible_valid / std::max<int64_t>(1, visible), res.timings.total_ms);
    if (out_dir.empty()) continue;
    std::vector<float> vals;  // colour range: 0.5th to 99.5th percentile of valid disparities
    for (int v = 0; v < l.rows; ++v)
      for (int u = 0; u < l.cols; ++u)
        if (res.valid.at<uint8_t>(v, u)) vals.push_back(res.disparity.at<float>(v, u));
    if (vals.empty()) continue;
    std::sort(vals.begin(), vals.end());
    const double lo = vals[vals.size() / 200], hi = vals[vals.size() - 1 - vals.size() / 200];
    cv::Mat small_d, small_t, small_v;
    const cv::Size preview(l.cols / 2, l.rows / 2);  // keeps each PNG well under 300 KB
    cv::resize(res.disparity, small_d, preview, 0, 0, cv::INTER_NEAREST);
    cv::resize(res.transformed, small_t, preview, 0, 0, cv::INTER_NEAREST);
    cv::resize(res.valid, small_v, preview, 0, 0, cv::INTER_NEAREST);
    const std::string base = out_dir + "/disparity_fan2021_model3_" + std::to_string(i);
    cv::imwrite(base + "_disparity.png", rs::ColorizeDisparity(small_d, small_v, std::floor(lo), std::ceil(hi)),
                {cv::IMWRITE_PNG_COMPRESSION, 9});
    cv::imwrite(base + "_transformed.png",
                rs::ColorizeDisparity(small_t, small_v, params.gpt_delta_px - 12, params.gpt_delta_px + 3),
                {cv::IMWRITE_PNG_COMPRESSION, 9});
  }
  return 0;
}

}  // namespace

// EuRoC ASL layout (raw pairs + sensor.yaml): rectified with StereoRectifier (alpha 0), GPT-SGM
// per chosen frame. Floor region, independent of GPT-SGM's dense output: pixels where a plain SGM
// run over [0, 64) lies within 1.5 px of the floor plane (GPT-SGM's road model, fitted to the
// sparse keypoint matches; the room's walls are the other planes) form the floor mask, which is
// closed (15x15) and hole-filled
// (so holes of either matcher count), reduced to its largest connected component and to pixels
// whose floor point lies inside the right image. Prints density of GPT-SGM inside it.
int RunEuroc(const std::string& mav0, const std::string& out_dir, rs::DisparityParams params) {
  namespace fs = std::filesystem;
  const rs::StereoCalibration raw =
      rs::ReadEurocSensorPair(fs::path(mav0) / "cam0/sensor.yaml", fs::path(mav0) / "cam1/sensor.yaml");
  const rs::StereoRectifier rectifier = rs::StereoRectifier::Create(raw, 0.0);
  std::vector<fs::path> lefts;
  for (const auto& e : fs::directory_iterator(fs::path(mav0) / "cam0/data")) lefts.push_back(e.path());
  std::sort(lefts.begin(), lefts.end());
  params.num_disparities = 64;
  std::printf("rectified: f = %.1f px, B = %.4f m, %dx%d\n", rectifier.rectified().left.fx,
              rectifier.rectified().BaselineM(), rectifier.rectified().left.width, rectifier.rectified().left.height);
  std::printf(
      "| frame | road (floor) model a0, a1, roll | matches / inliers | RMS px | fell back | range | valid (all) | "
      "floor pixels | valid on floor |\n"
      "|---|---|---|---|---|---|---|---|---|\n");
  for (size_t i = 0; i < lefts.size(); i += 15) {
    const fs::path rp = fs::path(mav0) / "cam1/data" / lefts[i].filename();
    cv::Mat l_raw = cv::imread(lefts[i].string(), cv::IMREAD_GRAYSCALE),
            r_raw = cv::imread(rp.string(), cv::IMREAD_GRAYSCALE);
    if (l_raw.empty() || r_raw.empty()) continue;  // cam1 lists stamps without images
    cv::Mat l, r;
    rectifier.Rectify(l_raw, r_raw, &l, &r);
    const rs::DisparityResult res = rs::ComputeDisparity(l, r, params);
    rs::DisparityParams plain = params;
    plain.method = rs::DisparityMethod::kSgm, plain.min_disparity = 0, plain.num_disparities = 64;
    const rs::DisparityResult ref = rs::ComputeDisparity(l, r, plain);
    cv::Mat floor = cv::Mat::zeros(l.size(), CV_8U);
    if (res.road.reliable && !res.fell_back) {
      for (int v = 0; v < l.rows; ++v)
        for (int u = 0; u < l.cols; ++u)
          if (ref.valid.at<uint8_t>(v, u) && std::abs(ref.disparity.at<float>(v, u) - res.road.At(u, v)) <= 1.5)
            floor.at<uint8_t>(v, u) = 255;
      cv::morphologyEx(floor, floor, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(15, 15)));
      cv::Mat holes = floor.clone();  // flood the background from the border; what is left unreached is a hole
      cv::copyMakeBorder(holes, holes, 1, 1, 1, 1, cv::BORDER_CONSTANT, 0);
      cv::floodFill(holes, cv::Point(0, 0), 255);
      floor |= ~holes(cv::Rect(1, 1, l.cols, l.rows));
      cv::Mat labels, stats, centroids;
      const int n = cv::connectedComponentsWithStats(floor, labels, stats, centroids, 8);
      int best = 0;
      for (int k = 1; k < n; ++k)
        if (best == 0 || stats.at<int>(k, cv::CC_STAT_AREA) > stats.at<int>(best, cv::CC_STAT_AREA)) best = k;
      floor = labels == best;
      if (best == 0) floor.setTo(0);
      for (int v = 0; v < l.rows; ++v)
        for (int u = 0; u < l.cols; ++u)
          if (u - res.road.At(u, v) < 0) floor.at<uint8_t>(v, u) = 0;
    }
    const int64_t n_floor = cv::countNonZero(floor), n_valid = cv::countNonZero(floor & res.valid);
    const rs::RoadModel& m = res.road;
    const std::string name = lefts[i].stem().string();
    std::printf("| %zu (%s) | %.2f, %.4f, %.2f deg | %d / %d | %.2f | %s | %d | %.1f %% | %lld | %.1f %% |\n", i,
                name.c_str(), m.a0, m.a1, m.roll_rad * 180 / M_PI, m.num_matches, m.num_inliers, m.residual_rms_px,
                res.fell_back ? "yes" : "no", res.num_disparities, 100 * res.valid_fraction,
                static_cast<long long>(n_floor), n_floor ? 100.0 * n_valid / n_floor : 0.0);
    if (out_dir.empty()) continue;
    const std::string base = out_dir + "/disparity_euroc_v101_" + std::to_string(i);
    cv::imwrite(base + "_disparity.jpg", rs::ColorizeDisparity(res.disparity, res.valid, 0, 48),
                {cv::IMWRITE_JPEG_QUALITY, 90});  // a PNG of this colour map is ~155 KB
    cv::Mat overlay;                              // left image with the floor region tinted
    cv::cvtColor(l, overlay, cv::COLOR_GRAY2BGR);
    overlay.setTo(cv::Scalar(0, 160, 0), floor & (res.valid == 0));
    for (int v = 0; v < l.rows; ++v)
      for (int u = 0; u < l.cols; ++u)
        if (floor.at<uint8_t>(v, u) && res.valid.at<uint8_t>(v, u)) {
          cv::Vec3b& c = overlay.at<cv::Vec3b>(v, u);
          c = {static_cast<uint8_t>(c[0] / 2), static_cast<uint8_t>(c[1] / 2 + 100), static_cast<uint8_t>(c[2] / 2)};
        }
    cv::imwrite(base + "_floor.jpg", overlay, {cv::IMWRITE_JPEG_QUALITY, 85});
  }
  return 0;
}

// Error map of GPT-SGM on a simulated pair: grey = not evaluated (darker: not road), green = road
// within 0.3 px, cyan = road 0.3..1 px, yellow = road 1..3 px, red = road D1 error, blue = road invalid, magenta =
// pothole error > 0.5 px. Written as <out>/<survey>_<frame>_errors.png.
void WriteErrorMap(const rs::StereoPairWithTruth& p, rs::DisparityParams params, const std::string& out) {
  params.camera_focal_px = p.focal_px;
  const rs::DisparityResult r = rs::ComputeDisparity(p.left, p.right, params);
  cv::Mat img;
  cv::cvtColor(p.left, img, cv::COLOR_GRAY2BGR);
  img = img * 0.5;
  for (int v = 0; v < p.gt.rows; ++v)
    for (int u = 0; u < p.gt.cols; ++u) {
      const float g = p.gt.at<float>(v, u);
      const bool ok = r.valid.at<uint8_t>(v, u) != 0;
      const double e = std::abs(r.disparity.at<float>(v, u) - g);
      cv::Vec3b& c = img.at<cv::Vec3b>(v, u);
      if (p.road.at<uint8_t>(v, u)) {
        if (!ok)
          c = {255, 0, 0};
        else if (e > 3 && e > 0.05 * g)
          c = {0, 0, 255};
        else if (e > 1)
          c = {0, 255, 255};
        else if (e > 0.3)
          c = {255, 255, 0};  // cyan: 0.3..1 px, already ~4-12 cm of depth at 6 m
        else
          c = {c[0], static_cast<uint8_t>(std::min(255, c[1] + 80)), c[2]};
      } else if (p.pothole.at<uint8_t>(v, u) && ok && e > 0.5) {
        c = {255, 0, 255};
      }
    }
  // Signed road error by the truth's fractional disparity (pixel locking shows as a sawtooth).
  double sum[10] = {0}, cnt[10] = {0}, total = 0, n_total = 0;
  for (int v = 0; v < p.gt.rows; ++v)
    for (int u = 0; u < p.gt.cols; ++u)
      if (p.road.at<uint8_t>(v, u) && r.valid.at<uint8_t>(v, u)) {
        const float g = p.gt.at<float>(v, u), e = r.disparity.at<float>(v, u) - g;
        if (std::abs(e) > 1) continue;
        const int b = std::min(9, static_cast<int>((g - std::floor(g)) * 10));
        sum[b] += e, cnt[b] += 1, total += e, n_total += 1;
      }
  std::printf("%s: road signed error mean %.3f px; by frac(gt) 0.0..0.9:", p.name.c_str(),
              total / std::max(1.0, n_total));
  for (int b = 0; b < 10; ++b) std::printf(" %.3f", cnt[b] ? sum[b] / cnt[b] : 0.0);
  std::printf("\n");
  std::string name = p.name;
  std::replace(name.begin(), name.end(), '/', '_');
  cv::imwrite(out + "/" + name + "_errors.png", img);
  // Signed error on the road, 128 + 400 err grey levels (+-0.32 px saturates): stripes and bands
  // the colour classes hide.
  cv::Mat signed_err(p.gt.size(), CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < p.gt.rows; ++v)
    for (int u = 0; u < p.gt.cols; ++u)
      if (p.road.at<uint8_t>(v, u) && r.valid.at<uint8_t>(v, u))
        signed_err.at<uint8_t>(v, u) =
            cv::saturate_cast<uint8_t>(128 + 400 * (r.disparity.at<float>(v, u) - p.gt.at<float>(v, u)));
  cv::imwrite(out + "/" + name + "_signed.png", signed_err);
  std::printf("%s: road model %s (matches %d, inliers %d, rms %.2f px, c = %.2f %.4f %.4f), fell back %d, range %d\n",
              p.name.c_str(), r.road.reliable ? "reliable" : "unreliable", r.road.num_matches, r.road.num_inliers,
              r.road.residual_rms_px, r.road.c[0], r.road.c[1], r.road.c[2], r.fell_back, r.num_disparities);
}

// Road error of GPT-SGM by row band (a forward view's range bins) per survey, pooled over its
// frames, plus each frame's overall line: "--sim-bands" (docs/stages/disparity.md, "Far road of
// the car view").
void PrintRoadBands(const std::vector<rs::StereoPairWithTruth>& pairs, const rs::DisparityParams& params) {
  std::map<std::string, std::pair<std::vector<rs::RoadBandStats>, rs::RoadErrorStats>> pooled;
  std::vector<std::string> order;
  for (const auto& p : pairs) {
    rs::DisparityParams q = params;
    q.camera_focal_px = p.focal_px;
    const rs::DisparityResult r = rs::ComputeDisparity(p.left, p.right, q);
    const int H = p.gt.rows;
    std::vector<int> edges;
    for (int e : {0, 280, 360, 440, 520, 600, 720}) edges.push_back(e * H / 720);
    const auto bands = rs::MeasureRoadErrorsByRows(p, r.disparity, r.valid, edges);
    const auto all = rs::MeasureRoadErrors(p, r.disparity, r.valid);
    const std::string survey = p.name.substr(0, p.name.rfind('/'));
    auto& [acc, acc_all] = pooled[survey];
    if (acc.empty())
      acc = bands, order.push_back(survey);
    else
      for (size_t b = 0; b < bands.size(); ++b) acc[b].Add(bands[b]);
    acc_all.Add(all);
    std::printf("%s: fell back %d; %s\n", p.name.c_str(), r.fell_back ? 1 : 0, all.Format().c_str());
  }
  for (const auto& survey : order) {
    const auto& [acc, all] = pooled[survey];
    std::printf(
        "\n%s (%s)\n| rows | road px | valid | mean truth d px | EPE px (|e|<=1) | signed mean px | row stripe RMS px "
        "| share |e|>1 |\n|---|---|---|---|---|---|---|---|\n",
        survey.c_str(), all.Format().c_str());
    for (const auto& b : acc)
      if (b.road)
        std::printf("| %d-%d | %lld | %.2f %% | %.1f | %.4f | %+.4f | %.4f | %.2f %% |\n", b.row_begin, b.row_end,
                    static_cast<long long>(b.road), 100.0 * b.valid / b.road, b.MeanTruth(), b.Epe(), b.SignedMean(),
                    b.StripeRms(), b.valid ? 100.0 * (b.valid - b.within_1) / b.valid : 0.0);
  }
}

int main(int argc, char** argv) {
  std::string data = std::getenv("ROADSURVEY_DATA") ? std::getenv("ROADSURVEY_DATA") : "";
  int reps = 5;
  bool middlebury = true;
  rs::DisparityParams params;
  int threads = 0;
  std::string fan_dir, out_dir, only, euroc_dir;
  double fan_scale = 1;
  std::vector<std::string> sims;
  int sim_range = 0;       // > 0: plain-SGM range of the simulated pairs instead of their truth's
  bool sim_bands = false;  // GPT-SGM's road error by row band instead of the benchmark table
  rs::SimulatedPairOptions sim_options;
  nlohmann::json option_json = rs::DisparityStageOptions::Table().ToJson(rs::DisparityStageOptions{});
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--data") && i + 1 < argc)
      data = argv[++i];
    else if (!std::strcmp(argv[i], "--reps") && i + 1 < argc)
      reps = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--no-middlebury"))
      middlebury = false;
    else if (!std::strcmp(argv[i], "--fan2021") && i + 1 < argc)
      fan_dir = argv[++i];
    else if (!std::strcmp(argv[i], "--out") && i + 1 < argc)
      out_dir = argv[++i];
    else if (!std::strcmp(argv[i], "--scale") && i + 1 < argc)
      fan_scale = std::atof(argv[++i]);
    else if (!std::strcmp(argv[i], "--only") && i + 1 < argc)
      only = argv[++i];
    else if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--paths") && i + 1 < argc)
      params.num_paths = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--gpt-range") && i + 1 < argc)
      params.gpt_num_disparities = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--sim") && i + 1 < argc)
      sims.push_back(argv[++i]);
    else if (!std::strcmp(argv[i], "--euroc") && i + 1 < argc)
      euroc_dir = argv[++i];
    else if (!std::strcmp(argv[i], "--sim-step") && i + 1 < argc)
      sim_options.frame_step = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--sim-frames") && i + 1 < argc)
      sim_options.max_frames = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--sim-first") && i + 1 < argc)
      sim_options.first_frame = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--sim-range") && i + 1 < argc)
      sim_range = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--sim-bands"))
      sim_bands = true;
    else if (!std::strcmp(argv[i], "--set") && i + 1 < argc) {
      const std::string kv = argv[++i];
      const auto eq = kv.find('=');
      if (eq == std::string::npos || !option_json.contains(kv.substr(0, eq))) {
        std::fprintf(stderr, "--set %s: expected NAME=VALUE with a disparity stage option NAME\n", kv.c_str());
        return 2;
      }
      try {
        option_json[kv.substr(0, eq)] = nlohmann::json::parse(kv.substr(eq + 1));
      } catch (const std::exception&) {
        option_json[kv.substr(0, eq)] = kv.substr(eq + 1);  // a bare word: an enum or string
      }
      const int paths = params.num_paths, range = params.gpt_num_disparities;
      params = rs::DisparityStageOptions::Table().FromJson(option_json).params;
      if (kv.substr(0, eq) != "num_paths") params.num_paths = paths;
      if (kv.substr(0, eq) != "gpt_num_disparities") params.gpt_num_disparities = range;
    } else {
      std::fprintf(stderr,
                   "usage: disparity_bench [--data DIR] [--reps N] [--no-middlebury] [--paths 4|8] [--gpt-range N] "
                   "[--threads N] [--only METHOD]\n"
                   "       disparity_bench --fan2021 MODEL3_DIR [--out DIR] [--scale S]\n"
                   "       disparity_bench --euroc MAV0_DIR [--out DIR]\n"
                   "       disparity_bench --sim SURVEY_DIR... [--sim-step N] [--sim-frames N] [--sim-first N] "
                   "[--sim-range N] [--sim-bands]\n"
                   "       (any: --set OPTION=VALUE)\n");
      return 2;
    }
  }
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0) {  // same thread budget for ours (oneTBB) and OpenCV
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
    cv::setNumThreads(threads);
  }
  try {
    params.Check();
    if (!fan_dir.empty()) return RunFan2021(fan_dir, out_dir, fan_scale, params);
    if (!euroc_dir.empty()) return RunEuroc(euroc_dir, out_dir, params);
    if (!sims.empty()) {
      std::vector<rs::StereoPairWithTruth> pairs;
      for (const auto& dir : sims) {
        auto p = rs::LoadSimulatedSurvey(dir, sim_options);
        pairs.insert(pairs.end(), std::make_move_iterator(p.begin()), std::make_move_iterator(p.end()));
      }
      if (sim_range > 0)
        for (auto& p : pairs) p.num_disparities = sim_range;
      if (sim_bands) {
        PrintRoadBands(pairs, params);
        return 0;
      }
      if (!out_dir.empty()) {
        for (const auto& p : pairs) WriteErrorMap(p, params, out_dir);
        return 0;
      }
      const auto results = rs::RunDisparityBenchmark(pairs, params, reps, only);
      std::printf("%s\n", rs::FormatRoadAccuracyTable(results).c_str());
      return 0;
    }
    std::vector<rs::StereoPairWithTruth> pairs;
    pairs.push_back(rs::MakeSyntheticRoadPair(rs::SyntheticRoadOptions{}));
    if (middlebury && !data.empty()) {
      auto mb = rs::LoadMiddlebury(data + "/middlebury");
      pairs.insert(pairs.end(), mb.begin(), mb.end());
    }
    const auto results = rs::RunDisparityBenchmark(pairs, params, reps, only);
    std::printf("%s\n%s\n", rs::FormatBenchmarkTable(results).c_str(), rs::FormatStepTimes(results).c_str());
    for (const auto& r : results)
      std::printf("%s: gpt-sgm/sgbm-3way time %.2f, sgm/sgbm-3way %.2f (medians of %d runs)\n", r.pair.c_str(),
                  r.Ratio("gpt-sgm", "sgbm-3way"), r.Ratio("sgm", "sgbm-3way"), reps);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "disparity_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
