// roadsurvey eval disparity|damage|cracks|trajectory|georeference|damage-sim|damage-map|pothole-scan: the stages'
// evaluation code on plain files (estimate first, truth second), a table for people and --json for machines.
#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "cli/command.h"
#include "cli/option_flags.h"
#include "cli/tool_util.h"
#include "formats/geojson/geojson.h"
#include "formats/input_error.h"
#include "formats/trajectory/trajectory_file.h"
#include "eval/damage/crack_folder_eval.h"
#include "eval/damage/crack_score.h"
#include "eval/damage/damage_eval.h"
#include "eval/damage/pothole_scan_eval.h"
#include "eval/damage/sim_damage_eval.h"
#include "eval/damage_map/damage_map_eval.h"
#include "eval/surface/pair_density.h"
#include "eval/surface/surface_eval.h"
#include "eval/disparity/disparity_eval.h"
#include "eval/georeference/georeference_eval.h"
#include "formats/disparity/disparity_io.h"
#include "eval/trajectory/trajectory_plot.h"
#include "eval/trajectory/trajectory_report.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

// ---------------------------------------------------------------- disparity

nlohmann::json ToJson(const DisparityMetrics& m) {
  if (m.evaluated == 0) return nullptr;
  return {{"evaluated", m.evaluated}, {"density", m.density}, {"bad1", m.bad1},         {"bad2", m.bad2},
          {"bad3", m.bad3},           {"d1", m.d1},           {"bad1_est", m.bad1_est}, {"bad2_est", m.bad2_est},
          {"bad3_est", m.bad3_est},   {"d1_est", m.d1_est},   {"epe_px", m.epe}};
}

std::string Row(const std::string& name, const std::string& region, const DisparityMetrics& m) {
  if (m.evaluated == 0) return fmt::format("{:<24} {:<7} {:>10}   (no truth pixels)\n", name, region, 0);
  return fmt::format("{:<24} {:<7} {:>10} {:>7.1f}% {:>7.2f}% {:>7.2f}% {:>7.2f}% {:>7.2f}% {:>7.3f}\n", name, region,
                     m.evaluated, 100 * m.density, 100 * m.bad1, 100 * m.bad2, 100 * m.bad3, 100 * m.d1, m.epe);
}

struct DisparityArgs {
  std::string est, gt, mask, noc, json;
};

int RunEvalDisparity(const DisparityArgs& a) {
  const auto pairs = PairFiles(a.est, a.gt, ".png");
  std::vector<FilePair> masks, nocs;
  if (!a.mask.empty()) masks = PairFiles(a.est, a.gt, ".png", a.mask);
  if (!a.noc.empty()) nocs = PairFiles(a.est, a.gt, ".png", a.noc);
  std::vector<DisparityMetrics> all, nonocc, masked;
  nlohmann::json files = nlohmann::json::array();
  std::string table = fmt::format("{:<24} {:<7} {:>10} {:>8} {:>8} {:>8} {:>8} {:>8} {:>7}\n", "file", "region",
                                  "pixels", "density", "bad-1", "bad-2", "bad-3", "D1", "EPE px");
  for (size_t i = 0; i < pairs.size(); ++i) {
    cv::Mat valid;
    const cv::Mat est = ReadKittiDisparityPng(pairs[i].est, &valid), gt = ReadKittiDisparityPng(pairs[i].truth);
    if (est.size() != gt.size())
      throw InputError(InputLocation::File(pairs[i].est.string()),
                       fmt::format("size {}x{} differs from the truth's {}x{}", est.cols, est.rows, gt.cols, gt.rows));
    auto region = [&](const FilePair& p) {
      const cv::Mat r = ReadImageAnyDepth(p.extra, false);
      if (r.size() != gt.size())
        throw InputError(InputLocation::File(p.extra.string()), "size differs from the truth's");
      cv::Mat grey = r;
      if (r.channels() > 1) cv::cvtColor(r, grey, cv::COLOR_BGR2GRAY);
      return cv::Mat(grey != 0);
    };
    all.push_back(EvaluateDisparity(est, valid, gt));
    nlohmann::json f = {{"name", pairs[i].name}, {"all", ToJson(all.back())}};
    table += Row(pairs[i].name, "all", all.back());
    if (!nocs.empty()) {
      nonocc.push_back(EvaluateDisparity(est, valid, gt, region(nocs[i])));
      f["nonocc"] = ToJson(nonocc.back());
      table += Row("", "noc", nonocc.back());
    }
    if (!masks.empty()) {
      masked.push_back(EvaluateDisparity(est, valid, gt, region(masks[i])));
      f["mask"] = ToJson(masked.back());
      table += Row("", "mask", masked.back());
    }
    files.push_back(std::move(f));
  }
  nlohmann::json total = {{"all", ToJson(PoolMetrics(all))}};
  if (pairs.size() > 1) table += Row(fmt::format("TOTAL ({} files)", pairs.size()), "all", PoolMetrics(all));
  if (!nocs.empty()) {
    total["nonocc"] = ToJson(PoolMetrics(nonocc));
    if (pairs.size() > 1) table += Row("", "noc", PoolMetrics(nonocc));
  }
  if (!masks.empty()) {
    total["mask"] = ToJson(PoolMetrics(masked));
    if (pairs.size() > 1) table += Row("", "mask", PoolMetrics(masked));
  }
  if (a.json != "-") fmt::print("{}", table);
  if (a.json != "-")
    fmt::print(
        "bad-N, D1: share of truth pixels with |d - gt| > N px (D1: > 3 px and > 5 %) or no estimate; "
        "EPE over valid estimates\n");
  if (!a.json.empty())
    WriteTextOutput(
        a.json,
        nlohmann::json{{"schema", "roadsurvey.eval_disparity/1"}, {"files", files}, {"total", total}}.dump(2) + "\n");
  return kExitOk;
}

// ---------------------------------------------------------------- damage

/// Single-channel label image (any channel non-zero counts for colour masks), CV_32S.
cv::Mat ReadLabels(const fs::path& path, bool components) {
  const cv::Mat image = ReadImageAnyDepth(path, false);
  cv::Mat labels;
  if (image.channels() == 1) {
    image.convertTo(labels, CV_32S);
  } else {
    std::vector<cv::Mat> ch;
    cv::split(image, ch);
    cv::Mat any = ch[0] != 0;
    for (size_t i = 1; i < ch.size(); ++i) any |= ch[i] != 0;
    any.convertTo(labels, CV_32S, 1.0 / 255);
  }
  if (components) {
    cv::Mat cc;
    cv::connectedComponents(labels != 0, cc, 8, CV_32S);
    return cc;
  }
  return labels;
}

double Field(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : std::numeric_limits<double>::quiet_NaN();
}

std::vector<DamageInstance> ReadDetections(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open detections JSON");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(InputLocation::Byte(path.string(), int64_t(e.byte)), e.what());
  }
  if (!j.is_object() || !j.contains("detections") || !j["detections"].is_array())
    throw InputError(InputLocation::File(path.string()), "expected {\"detections\": [...]}");
  std::vector<DamageInstance> out;
  for (const auto& d : j["detections"]) {
    if (!d.is_object() || !d.contains("id") || !d["id"].is_number_integer())
      throw InputError(InputLocation::File(path.string()), "a detection without an integer \"id\"");
    DamageInstance inst;
    inst.id = d["id"].get<int>();
    inst.area_m2 = Field(d, "area_m2"), inst.max_depth_m = Field(d, "max_depth_m"),
    inst.volume_m3 = Field(d, "volume_m3");
    out.push_back(inst);
  }
  return out;
}

std::vector<TruthInstance> ReadTruthGeoJson(const fs::path& path) {
  const geojson::FeatureCollection fc = geojson::ReadFeatureCollection(path);
  std::vector<TruthInstance> out;
  for (size_t i = 0; i < fc.features.size(); ++i) {
    const nlohmann::json& p = fc.features[i].properties;
    if (!p.is_object() || !p.contains("id") || !p["id"].is_number_integer())
      throw InputError(InputLocation::File(path.string()),
                       fmt::format("feature {} has no integer \"id\" property (the mask label)", i));
    TruthInstance t;
    t.id = p["id"].get<int>();
    t.area_m2 = Field(p, "area_m2"), t.max_depth_m = Field(p, "max_depth_m"), t.volume_m3 = Field(p, "volume_m3");
    out.push_back(t);
  }
  return out;
}

struct DamageArgs {
  std::string labels, truth_masks, detections, truth, json;
  bool components = false;
  double min_iou = 0.5;
  double tolerance_px = -1;  ///< crack scoring: predicted/true pixels within this distance count (< 0 = off)
};

nlohmann::json ToJson(const TolerantPixelScore& s, double tolerance_px) {
  return {{"tolerance_px", tolerance_px},    {"predicted", s.predicted}, {"predicted_near", s.predicted_near},
          {"truth", s.truth},                {"truth_near", s.truth_near}, {"precision", s.Precision()},
          {"recall", s.Recall()},            {"f1", s.F1()}};
}

/// Count, mean signed error (bias) and mean absolute error of finite values.
struct ErrorSummary {
  int n = 0;
  double bias = 0, mae = 0;
  void Add(double e) {
    if (std::isfinite(e)) ++n, bias += e, mae += std::abs(e);
  }
  nlohmann::json Json() const {
    if (n == 0) return nullptr;
    return {{"count", n}, {"bias", bias / n}, {"mean_abs", mae / n}};
  }
};

int RunEvalDamage(const DamageArgs& a) {
  const auto pairs = PairFiles(a.labels, a.truth_masks, ".png");
  std::vector<TruthInstance> truth;
  if (!a.truth.empty()) truth = ReadTruthGeoJson(a.truth);
  PixelMetrics pooled;
  int predicted = 0, truth_n = 0, tp = 0;
  ErrorSummary area, depth, volume;
  TolerantPixelScore tolerant_total;
  std::string tolerant_table = fmt::format("{:<24} {:>9} {:>7} {:>7}\n", "file", "precision", "recall", "F1");
  nlohmann::json files = nlohmann::json::array();
  std::string table = fmt::format("{:<24} {:>9} {:>7} {:>7} {:>7} {:>5} {:>5} {:>4} {:>4} {:>4}\n", "file", "precision",
                                  "recall", "F1", "IoU", "pred", "truth", "TP", "FP", "FN");
  for (const auto& p : pairs) {
    const cv::Mat pred = ReadLabels(p.est, false), gt = ReadLabels(p.truth, a.components);
    if (pred.size() != gt.size())
      throw InputError(InputLocation::File(p.est.string()), fmt::format("size {}x{} differs from the truth's {}x{}",
                                                                        pred.cols, pred.rows, gt.cols, gt.rows));
    std::vector<DamageInstance> dets;
    if (!a.detections.empty()) {
      const fs::path json = fs::path(a.detections) / (fs::path(p.name).stem().string() + ".json");
      dets = ReadDetections(json);
    }
    const PixelMetrics px = ComparePixels(pred != 0, gt != 0);
    pooled.Add(px);
    TolerantPixelScore tolerant;
    if (a.tolerance_px >= 0) {
      tolerant = ScoreCrackPixels(pred != 0, gt != 0, a.tolerance_px);
      tolerant_total += tolerant;
      tolerant_table += fmt::format("{:<24} {:>9.3f} {:>7.3f} {:>7.3f}\n", p.name, tolerant.Precision(),
                                    tolerant.Recall(), tolerant.F1());
    }
    const InstanceEvaluation inst = MatchInstances(pred, gt, dets, truth, a.min_iou);
    predicted += inst.predicted, truth_n += inst.truth, tp += int(inst.matches.size());
    nlohmann::json matches = nlohmann::json::array();
    for (const auto& m : inst.matches) {
      area.Add(m.area_error_m2), depth.Add(m.max_depth_error_m), volume.Add(m.volume_error_m3);
      auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
      matches.push_back({{"predicted_id", m.predicted_id},
                         {"truth_id", m.truth_id},
                         {"iou", m.iou},
                         {"area_error_m2", num(m.area_error_m2)},
                         {"max_depth_error_m", num(m.max_depth_error_m)},
                         {"volume_error_m3", num(m.volume_error_m3)}});
    }
    table += fmt::format("{:<24} {:>9.3f} {:>7.3f} {:>7.3f} {:>7.3f} {:>5} {:>5} {:>4} {:>4} {:>4}\n", p.name,
                         px.precision, px.recall, px.f1, px.iou, inst.predicted, inst.truth, inst.matches.size(),
                         inst.false_positives, inst.false_negatives);
    files.push_back({{"name", p.name},
                     {"pixels",
                      {{"tp", px.tp},
                       {"fp", px.fp},
                       {"fn", px.fn},
                       {"precision", px.precision},
                       {"recall", px.recall},
                       {"f1", px.f1},
                       {"iou", px.iou}}},
                     {"instances",
                      {{"predicted", inst.predicted},
                       {"truth", inst.truth},
                       {"false_positives", inst.false_positives},
                       {"false_negatives", inst.false_negatives},
                       {"matches", matches}}}});
    if (a.tolerance_px >= 0) files.back()["crack_pixels"] = ToJson(tolerant, a.tolerance_px);
  }
  pooled.Finish();
  const double ip = predicted ? double(tp) / predicted : 0, ir = truth_n ? double(tp) / truth_n : 0;
  const double if1 = ip + ir > 0 ? 2 * ip * ir / (ip + ir) : 0;
  table += fmt::format("{:<24} {:>9.3f} {:>7.3f} {:>7.3f} {:>7.3f} {:>5} {:>5} {:>4} {:>4} {:>4}\n",
                       fmt::format("TOTAL ({} files)", pairs.size()), pooled.precision, pooled.recall, pooled.f1,
                       pooled.iou, predicted, truth_n, tp, predicted - tp, truth_n - tp);
  if (a.json != "-") fmt::print("{}", table);
  if (a.json != "-")
    fmt::print(
        "pixels: damage vs no damage, pooled over files; instances: one-to-one at IoU >= {:.2f}: "
        "precision {:.3f}, recall {:.3f}, F1 {:.3f}\n",
        a.min_iou, ip, ir, if1);
  auto line = [](const char* what, const ErrorSummary& s, double unit, const char* u) {
    if (s.n == 0) return fmt::format("  {:<10} no pair with both values\n", what);
    return fmt::format("  {:<10} bias {:+.4g} {}, mean |error| {:.4g} {} over {} matches\n", what, s.bias / s.n * unit,
                       u, s.mae / s.n * unit, u, s.n);
  };
  if (a.json != "-" && a.tolerance_px >= 0)
    fmt::print("crack pixels within {} px (precision: predicted pixels near a true one; recall: true pixels near a "
               "predicted one):\n{}{:<24} {:>9.3f} {:>7.3f} {:>7.3f}\n",
               a.tolerance_px, tolerant_table, fmt::format("TOTAL ({} files)", pairs.size()),
               tolerant_total.Precision(), tolerant_total.Recall(), tolerant_total.F1());
  if (a.json != "-" && (!a.detections.empty() || !a.truth.empty()))
    fmt::print("measurement errors (predicted - truth):\n{}{}{}", line("area", area, 1e4, "cm2"),
               line("max depth", depth, 1e3, "mm"), line("volume", volume, 1e6, "cm3"));
  if (!a.json.empty()) {
    nlohmann::json total = {{"pixels",
                             {{"tp", pooled.tp},
                              {"fp", pooled.fp},
                              {"fn", pooled.fn},
                              {"precision", pooled.precision},
                              {"recall", pooled.recall},
                              {"f1", pooled.f1},
                              {"iou", pooled.iou}}},
                            {"instances",
                             {{"predicted", predicted},
                              {"truth", truth_n},
                              {"matched", tp},
                              {"precision", ip},
                              {"recall", ir},
                              {"f1", if1},
                              {"min_iou", a.min_iou}}},
                            {"area_error_m2", area.Json()},
                            {"max_depth_error_m", depth.Json()},
                            {"volume_error_m3", volume.Json()}};
    if (a.tolerance_px >= 0) total["crack_pixels"] = ToJson(tolerant_total, a.tolerance_px);
    WriteTextOutput(
        a.json,
        nlohmann::json{{"schema", "roadsurvey.eval_damage/1"}, {"files", files}, {"total", total}}.dump(2) + "\n");
  }
  return kExitOk;
}

// ---------------------------------------------------------------- cracks (images + masks)

struct CracksArgs {
  std::string dir, json, debug;
  double tolerance_px = 2;
  int max_images = 0;
  std::string detector = "auto", model;
  OptionFlags flags;  // --crack.<option>
};

int RunEvalCracks(const CracksArgs& a) {
  const auto& options_table = CrackOptions::Table();
  const nlohmann::json overrides = a.flags.Overrides();
  nlohmann::json oj =
      overrides.contains("crack") ? options_table.Merge(overrides["crack"], "crack") : options_table.Defaults();
  oj["detector"] = a.detector;
  oj["model"] = a.model;
  CrackOptions options = options_table.FromJson(oj);
  options.Check();
  const CrackFolderEvaluation e = EvaluateCrackFolder(a.dir, options, a.tolerance_px, a.max_images, a.debug);
  nlohmann::json images = nlohmann::json::array();
  std::string table = fmt::format("{:<32} {:>9} {:>7} {:>7} {:>6}\n", "image", "precision", "recall", "F1", "cracks");
  for (const CrackFolderImage& r : e.images) {
    table += fmt::format("{:<32} {:>9.3f} {:>7.3f} {:>7.3f} {:>6}\n", r.name, r.score.Precision(), r.score.Recall(),
                         r.score.F1(), r.cracks);
    nlohmann::json j = ToJson(r.score, a.tolerance_px);
    j["name"] = r.name;
    j["cracks"] = r.cracks;
    images.push_back(j);
  }
  table += fmt::format("{:<32} {:>9.3f} {:>7.3f} {:>7.3f}\n", fmt::format("TOTAL ({} images)", e.images.size()),
                       e.overall.Precision(), e.overall.Recall(), e.overall.F1());
  if (a.json != "-")
    fmt::print(
        "{}crack pixels within {} px, pooled over the images; {} of {} images without a detected crack, {} "
        "without a true crack pixel\n"
        "detector {}: precision {:.3f}, recall {:.3f}, F1 {:.3f}; wall {:.1f} s, detection {:.1f} ms per image\n",
        table, a.tolerance_px, e.images_without_crack, e.images.size(), e.images_without_truth, e.detector,
        e.overall.Precision(), e.overall.Recall(), e.overall.F1(), e.wall_s,
        1e3 * e.detect_s / std::max<size_t>(1, e.images.size()));
  if (!a.json.empty()) {
    nlohmann::json total = ToJson(e.overall, a.tolerance_px);
    total["images"] = e.images.size();
    total["images_without_crack"] = e.images_without_crack;
    total["images_without_truth"] = e.images_without_truth;
    total["detector"] = e.detector;
    total["wall_s"] = e.wall_s;
    total["detect_s"] = e.detect_s;
    WriteTextOutput(a.json,
                    nlohmann::json{{"schema", "roadsurvey.eval_cracks/1"}, {"images", images}, {"total", total}}.dump(2) +
                        "\n");
  }
  return kExitOk;
}

// ---------------------------------------------------------------- trajectory

/// "5" or "5f" frames, "1.5s" seconds, "100m" metres.
RelativeDelta ParseDelta(const std::string& text, const std::string& flag) {
  RelativeDelta d;
  std::string number = text;
  if (!text.empty() && std::string("fsm").find(text.back()) != std::string::npos) {
    d.unit = text.back() == 's'   ? RelativeDelta::Unit::kSeconds
             : text.back() == 'm' ? RelativeDelta::Unit::kMeters
                                  : RelativeDelta::Unit::kFrames;
    number.pop_back();
  }
  size_t used = 0;
  try {
    d.value = std::stod(number, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  const bool whole = d.unit != RelativeDelta::Unit::kFrames || d.value == std::floor(d.value);
  if (number.empty() || used != number.size() || !(d.value > 0) || !std::isfinite(d.value) || !whole)
    throw OptionError(
        fmt::format("{} = '{}' violates N (frames, whole), Ns (seconds) or Nm (metres) with N > 0", flag, text));
  return d;
}

int64_t SecondsToNs(double s, const std::string& flag) {
  if (!std::isfinite(s) || std::abs(s) > 9e9) throw OptionError(fmt::format("{} = {} is not a usable time", flag, s));
  return std::llround(s * 1e9);
}

struct GeoreferenceArgs {
  std::string output, truth, json;
  bool no_colmap = false;
};

int RunEvalGeoreference(const GeoreferenceArgs& a) {
  const GeoreferenceEvaluation ev = EvaluateGeoreference(a.output, a.truth, !a.no_colmap);
  if (a.json != "-") fmt::print("{}", ev.BriefReport());
  if (!a.json.empty()) WriteTextOutput(a.json, ev.ToJson().dump(2) + "\n");
  return kExitOk;
}

struct TrajectoryArgs {
  std::string est, gt, align = "se3", format = "auto", gt_format = "auto", kitti_times, json, plot;
  bool by_index = false;
  double max_time_diff_s = 0.02, time_offset_s = 0;
  std::string rde_delta = "1", rpe_delta = "1";
};

int RunEvalTrajectory(const TrajectoryArgs& a) {
  TrajectoryEvalOptions o;
  o.alignment = *ParseTrajectoryAlignment(a.align);
  o.associate_by_index = a.by_index;
  o.max_time_difference_ns = SecondsToNs(a.max_time_diff_s, "--max-time-diff");
  o.est_time_offset_ns = SecondsToNs(a.time_offset_s, "--time-offset");
  o.rde_delta = ParseDelta(a.rde_delta, "--rde-delta");
  o.rpe_delta = ParseDelta(a.rpe_delta, "--rpe-delta");
  if (const std::string problem = o.Check(); !problem.empty()) throw OptionError(problem);
  auto format = [](const std::string& name) { return name == "auto" ? std::nullopt : ParseTrajectoryFormat(name); };
  std::optional<fs::path> times;
  if (!a.kitti_times.empty()) times = a.kitti_times;
  const Trajectory est = ReadTrajectory(a.est, format(a.format), times);
  const Trajectory gt = ReadTrajectory(a.gt, format(a.gt_format), times);
  if (!o.associate_by_index && (!est.has_times || !gt.has_times)) {
    o.associate_by_index = true;
    fmt::print(stderr, "note: {} has no timestamps (KITTI poses without --kitti-times): associating by index\n",
               est.has_times ? a.gt : a.est);
  }
  const TrajectoryEvalReport report = EvaluateTrajectory(est, gt, o);
  if (a.json != "-") fmt::print("{}", FormatTrajectoryEvalTable(report));
  if (!a.json.empty()) WriteTextOutput(a.json, TrajectoryEvalReportToJson(report).dump(2) + "\n");
  if (!a.plot.empty()) {
    const PosePairs pairs = o.associate_by_index
                                ? AssociateByIndex(est, gt)
                                : AssociateByTimestamp(est, gt, o.max_time_difference_ns, o.est_time_offset_ns);
    TrajectoryPlotOptions po;
    po.title = fmt::format("{} vs {} ({} alignment)", a.est, a.gt, a.align);
    WriteTrajectoryPlot(a.plot, pairs, report.ate.alignment, po);
  }
  return kExitOk;
}

// ---------------------------------------------------------------- simulated survey (damage end to end)

struct SimDamageArgs {
  std::string survey_dir;
  bool truth_disparity = false;
  int step = 1, max_frames = 0;
  double max_range_m = 0, min_diameter_m = 0.3;
};

int RunEvalSimulatedDamage(const SimDamageArgs& a) {
  SimDamageEvalOptions o;
  o.use_truth_disparity = a.truth_disparity;
  o.frame_step = a.step;
  o.max_frames = a.max_frames;
  o.max_range_m = a.max_range_m;
  o.min_diameter_m = a.min_diameter_m;
  SimDamageEvaluation e;
  CheckAsOption([&] { e = EvaluateSimulatedDamage(a.survey_dir, o); });
  fmt::print("{}\n", e.Report());
  return kExitOk;
}

// ---------------------------------------------------------------- damage map of a simulated survey

struct DamageMapArgs {
  std::string survey_dir, output, json;
  DamageMapEvalOptions options;
  double depth_tolerance_mm = 10;
};

int RunEvalDamageMap(DamageMapArgs a) {
  a.options.depth_tolerance_m = a.depth_tolerance_mm / 1000;
  CheckAsOption([&] { a.options.Check(); });
  const DamageMapEvaluation e = EvaluateDamageMap(a.survey_dir, a.output, a.options);
  if (a.json != "-") fmt::print("{}", e.Table());
  if (!a.json.empty()) WriteTextOutput(a.json, e.ToJson().dump(2) + "\n");
  return kExitOk;
}

// ---------------------------------------------------------------- surface products of a simulated survey

struct SurfaceArgs {
  std::string survey_dir, output, json, error_image;
};

int RunEvalSurface(const SurfaceArgs& a) {
  const SurfaceEvaluation e = EvaluateSurface(a.survey_dir, a.output, a.error_image);
  if (a.json != "-") fmt::print("{}", e.Table());
  if (!a.json.empty()) WriteTextOutput(a.json, e.ToJson().dump(2) + "\n");
  return kExitOk;
}

struct SurfacePairsArgs {
  std::string dir, json;
  std::vector<double> cells_m = {0.01, 0.002};
};

int RunEvalSurfacePairs(const SurfacePairsArgs& a) {
  const std::vector<PairDensityRow> rows = EvaluatePairDensity(a.dir, a.cells_m);
  fmt::print("{}", PairDensityTable(rows));
  if (!a.json.empty()) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& r : rows)
      j.push_back({{"pair", r.left}, {"cell_m", r.cell_m}, {"pixel_m", r.pixel_m}, {"visible_cells", r.visible_cells},
                   {"filled_cells", r.filled_cells}, {"filled_fraction", r.filled_fraction},
                   {"pixel_density", r.pixel_density}});
    WriteTextOutput(a.json, j.dump(2) + "\n");
  }
  return kExitOk;
}

struct PotholeScanArgs {
  std::string dir;
  std::vector<int> pairs = {1, 3, 4, 5};
  double max_depth_m = 0.1;
  bool smooth = false;
  std::string json;
};

int RunEvalPotholeScan(const PotholeScanArgs& a) {
  PotholeScanOptions o;
  o.max_depth_m = a.max_depth_m;
  o.sharp = !a.smooth;
  std::vector<PotholeScanRow> rows;
  CheckAsOption([&] { rows = EvaluatePotholeScans(a.dir, a.pairs, o); });
  fmt::print("{}", PotholeScanTable(rows));
  if (!a.json.empty()) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& r : rows)
      j.push_back({{"pair", r.pair},
                   {"scan", r.scan},
                   {"camera_height_m", r.result.camera_height_m},
                   {"delta_px", r.result.delta_px},
                   {"num_disparities", r.result.num_disparities},
                   {"road_sigma_mm", r.result.road_sigma_mm},
                   {"cut_mm", r.result.cut_mm},
                   {"region_px", r.result.region_px},
                   {"points", r.result.points},
                   {"max_depth_mm", r.result.max_depth_mm},
                   {"scan_depth_mm", r.result.scan_depth_mm},
                   {"rms_mm", r.result.rms_mm},
                   {"median_mm", r.result.median_mm}});
    WriteTextOutput(a.json, nlohmann::json{{"schema", "roadsurvey.eval_pothole_scan/1"}, {"rows", j}}.dump(2) + "\n");
  }
  return kExitOk;
}

}  // namespace

Command EvalCommand() {
  return {
      "eval",
      "Evaluate results against ground truth: disparity maps, damage labels, damage maps, trajectories, "
      "georeferencing, potholes vs laser scans",
      [](CLI::App& app, const StageRegistry&) -> std::function<int()> {
        app.option_defaults()->always_capture_default();
        app.require_subcommand(1);
        auto d = std::make_shared<DisparityArgs>();
        CLI::App* disp = app.add_subcommand("disparity", "KITTI 16-bit disparity PNGs vs truth: bad-1/2/3, D1, EPE");
        disp->add_option("estimate", d->est, "estimated disparity PNG, or a folder of them")->required();
        disp->add_option("truth", d->gt, "truth disparity PNG (0 = unknown), or a folder (paired by file name)")
            ->required();
        disp->add_option("--noc", d->noc,
                         "non-occluded region: KITTI disp_noc PNG/folder (non-zero pixels are evaluated)");
        disp->add_option("--mask", d->mask, "evaluation mask PNG/folder (non-zero = evaluate), e.g. road pixels");
        disp->add_option("--json", d->json, "write the metrics as JSON ('-' = stdout)");

        auto g = std::make_shared<DamageArgs>();
        CLI::App* dmg = app.add_subcommand("damage", "damage label PNGs vs truth masks: pixel and instance metrics");
        dmg->add_option("labels", g->labels, "predicted 16-bit instance label PNG, or a folder of them")->required();
        dmg->add_option("truth", g->truth_masks, "truth mask/label PNG, or a folder (paired by file name)")->required();
        dmg->add_option("--detections", g->detections,
                        "folder of detections JSON (<frame>.json) with the predicted measurements");
        dmg->add_option("--truth", g->truth, "truth damages.geojson (properties id, area_m2, max_depth_m, volume_m3)");
        dmg->add_flag("--components", g->components,
                      "truth is a binary mask: its 8-connected components are the truth instances");
        dmg->add_option("--min-iou", g->min_iou, "IoU a predicted and a truth instance need to match")
            ->check(CLI::Range(0.01, 1.0));
        dmg->add_option("--json", g->json, "write the metrics as JSON ('-' = stdout)");
        dmg->add_option("--tolerance-px", g->tolerance_px,
                        "also score crack pixels: predicted and true pixels within this distance count (e.g. 2)")
            ->check(CLI::NonNegativeNumber);

        auto c = std::make_shared<CracksArgs>();
        CLI::App* crk = app.add_subcommand(
            "cracks", "crack detection (pixel units) on a folder of images/ and masks/: precision, recall, F1");
        crk->add_option("dir", c->dir, "folder with images/NAME and masks/NAME (crack = mask grey >= 128)")->required();
        crk->add_option("--tolerance-px", c->tolerance_px, "predicted and true pixels within this distance count")
            ->check(CLI::NonNegativeNumber);
        crk->add_option("--max-images", c->max_images, "score every n-th pair, at most this many (0 = all)")
            ->check(CLI::NonNegativeNumber);
        crk->add_option("--debug", c->debug, "write image | truth (green) | detection (magenta) PNGs to this folder");
        crk->add_option("--json", c->json, "write the metrics as JSON ('-' = stdout)");
        crk->add_option("--detector", c->detector,
                        "auto (the learned model when its file exists, else ridge), learned, ridge or black-hat")
            ->check(CLI::IsMember({"auto", "learned", "ridge", "black-hat"}));
        crk->add_option("--model", c->model, "learned crack model (ONNX, its .json beside it; default: the committed one)");
        c->flags.Add(*crk, "crack", CrackOptions::Table(), "Crack options (the damage stage's crack.*)",
                     {"detector", "model"});

        auto t = std::make_shared<TrajectoryArgs>();
        CLI::App* traj = app.add_subcommand("trajectory", "estimated vs truth trajectory: ATE, RDE, RPE, KITTI errors");
        traj->add_option("estimate", t->est, "estimated trajectory (TUM, KITTI or EuRoC)")->required();
        traj->add_option("truth", t->gt, "truth trajectory")->required();
        traj->add_option("--align", t->align, "fit before ATE")->check(CLI::IsMember({"se3", "sim3", "none"}));
        traj->add_flag("--by-index", t->by_index, "pair pose i with pose i instead of by timestamp");
        traj->add_option("--max-time-diff", t->max_time_diff_s, "timestamp association tolerance, s")
            ->check(CLI::NonNegativeNumber);
        traj->add_option("--time-offset", t->time_offset_s, "added to the estimate's times before association, s");
        traj->add_option("--rde-delta", t->rde_delta, "RDE pair spacing: N frames, Ns seconds or Nm metres");
        traj->add_option("--rpe-delta", t->rpe_delta, "RPE pair spacing: N frames, Ns seconds or Nm metres");
        const std::vector<std::string> formats = {"auto", "tum", "kitti", "euroc"};
        traj->add_option("--format", t->format, "estimate format (auto: from the first data line)")
            ->check(CLI::IsMember(formats));
        traj->add_option("--gt-format", t->gt_format, "truth format")->check(CLI::IsMember(formats));
        traj->add_option("--kitti-times", t->kitti_times, "times.txt for KITTI-format inputs (seconds per line)");
        traj->add_option("--json", t->json, "write the report as JSON ('-' = stdout)");
        traj->add_option("--plot", t->plot, "write a PNG: top view of both paths after alignment, ATE over time");

        auto geo = std::make_shared<GeoreferenceArgs>();
        CLI::App* georef = app.add_subcommand(
            "georeference", "cameras.csv of a simulated survey vs truth, beside COLMAP model_aligner on the same input");
        georef->add_option("output", geo->output, "the survey's output folder (cameras.csv, trajectory.tum, work/)")
            ->required();
        georef->add_option("truth", geo->truth, "the simulator's truth/ folder")->required();
        georef->add_flag("--no-colmap", geo->no_colmap, "skip COLMAP model_aligner");
        georef->add_option("--json", geo->json, "write the evaluation as JSON ('-' = stdout)");

        auto sd = std::make_shared<SimDamageArgs>();
        CLI::App* sim = app.add_subcommand(
            "damage-sim", "a simulated survey end to end: disparity + damage vs the simulator's truth potholes");
        sim->add_option("survey", sd->survey_dir, "folder written by `roadsurvey simulate`")->required();
        sim->add_flag("--truth-disparity", sd->truth_disparity,
                      "use truth/disparity instead of computing it (isolates the damage stage)");
        sim->add_option("--step", sd->step, "evaluate every n-th frame")->check(CLI::PositiveNumber);
        sim->add_option("--max-frames", sd->max_frames, "at most this many frames (0 = all)")
            ->check(CLI::NonNegativeNumber);
        sim->add_option("--max-range", sd->max_range_m,
                        "only potholes nearer than this camera depth, m (0 = the damage stage's analysed range)")
            ->check(CLI::NonNegativeNumber);
        sim->add_option("--min-diameter", sd->min_diameter_m, "truth potholes at least this wide are scored, m")
            ->check(CLI::PositiveNumber);

        auto dm = std::make_shared<DamageMapArgs>();
        CLI::App* dmap = app.add_subcommand(
            "damage-map", "a simulated survey's damage.geojson (after `roadsurvey run`) vs the simulator's truth");
        dmap->add_option("survey", dm->survey_dir, "folder written by `roadsurvey simulate`")->required();
        dmap->add_option("--output", dm->output, "the run's output folder (default: survey.json's \"output\")");
        dmap->add_option("--json", dm->json, "write the evaluation as JSON ('-' = stdout)");
        dmap->add_flag("--absolute", [dm](int64_t) { dm->options.remove_placement_offset = false; },
                       "match the map as it stands (default: the cameras' mean placement error, from "
                       "cameras.csv against the truth poses, is removed first; absolute errors are reported either way)");
        dmap->add_option("--min-pothole-diameter", dm->options.min_pothole_diameter_m,
                         "truth potholes at least this wide (mean_diameter_m) are scored, m")
            ->check(CLI::NonNegativeNumber);
        dmap->add_option("--min-overlap", dm->options.min_overlap,
                         "pothole match: intersection / min(area predicted, area truth) on the road plane")
            ->check(CLI::Range(0.01, 1.0));
        dmap->add_option("--min-crack-length", dm->options.min_crack_length_m,
                         "truth cracks at least this long (length_m) are scored, m")
            ->check(CLI::NonNegativeNumber);
        dmap->add_option("--crack-tolerance", dm->options.crack_tolerance_m,
                         "a true crack point is covered within this distance of a predicted crack line, m")
            ->check(CLI::PositiveNumber);
        dmap->add_option("--min-crack-coverage", dm->options.min_crack_coverage,
                         "crack match: share of the true line covered")
            ->check(CLI::Range(0.01, 1.0));
        dmap->add_option("--min-pixels", dm->options.min_seen_pixels,
                         "a truth damage is seen whole in a frame with at least this many mask pixels...")
            ->check(CLI::PositiveNumber);
        dmap->add_option("--border-px", dm->options.border_px, "... none of them in the image's outer N px")
            ->check(CLI::NonNegativeNumber);
        dmap->add_option("--depth-tolerance", dm->depth_tolerance_mm, "summary tolerance of |max depth error|, mm")
            ->check(CLI::PositiveNumber);
        dmap->add_option("--area-tolerance", dm->options.area_tolerance_pct, "summary tolerance of |area error|, %")
            ->check(CLI::PositiveNumber);
        dmap->add_option("--volume-tolerance", dm->options.volume_tolerance_pct,
                         "summary tolerance of |volume error|, %")
            ->check(CLI::PositiveNumber);

        auto sf = std::make_shared<SurfaceArgs>();
        CLI::App* surf = app.add_subcommand(
            "surface", "a simulated survey's surface/dsm.tif and mesh.ply (after `roadsurvey run`) vs truth/road_surface.ply");
        surf->add_option("survey", sf->survey_dir, "folder written by `roadsurvey simulate`")->required();
        surf->add_option("--output", sf->output, "the run's output folder (default: survey.json's \"output\")");
        surf->add_option("--json", sf->json, "write the evaluation as JSON ('-' = stdout)");
        surf->add_option("--error-image", sf->error_image,
                         "write DSM - truth (cameras' error removed) as a PNG, +-20 mm through the turbo colour map");

        auto sp = std::make_shared<SurfacePairsArgs>();
        CLI::App* spairs = app.add_subcommand(
            "surface-pairs", "surface grid density of single real pairs without poses (Fan 2021 model3 layout)");
        spairs->add_option("dir", sp->dir, "folder with left images/L<i>.png, right images/R<i>.png, calibration_rectified.yaml")
            ->required()
            ->check(CLI::ExistingDirectory);
        spairs->add_option("--cells", sp->cells_m, "grid cells to measure at, m")->delimiter(',');
        spairs->add_option("--json", sp->json, "also write the rows as JSON");

        auto ps = std::make_shared<PotholeScanArgs>();
        CLI::App* scan = app.add_subcommand(
            "pothole-scan",
            "potholes reconstructed at full resolution vs laser scans (Fan 2021 model3): ICP, RMS closest-point distance");
        scan->add_option("model3", ps->dir, "the model3 folder (left images/, right images/, gt/, calibration_rectified.yaml)")
            ->required()
            ->check(CLI::ExistingDirectory);
        scan->add_option("--pairs", ps->pairs, "the pair of each scan in order: gt/model_1.ply, gt/model_2.ply, ...")
            ->delimiter(',');
        scan->add_option("--max-depth", ps->max_depth_m, "deepest damage the GPT-SGM range must hold, m")
            ->check(CLI::PositiveNumber);
        scan->add_flag("--smooth", ps->smooth, "reconstruct from the smooth disparity instead of disparity_sharp");
        scan->add_option("--json", ps->json, "write the rows as JSON ('-' = stdout)");

        return [=] {
          if (scan->parsed()) return RunEvalPotholeScan(*ps);
          if (sim->parsed()) return RunEvalSimulatedDamage(*sd);
          if (dmap->parsed()) return RunEvalDamageMap(*dm);
          if (surf->parsed()) return RunEvalSurface(*sf);
          if (spairs->parsed()) return RunEvalSurfacePairs(*sp);
          if (disp->parsed()) return RunEvalDisparity(*d);
          if (georef->parsed()) return RunEvalGeoreference(*geo);
          if (dmg->parsed()) return RunEvalDamage(*g);
          if (crk->parsed()) return RunEvalCracks(*c);
          return RunEvalTrajectory(*t);
        };
      }};
}

}  // namespace rs
