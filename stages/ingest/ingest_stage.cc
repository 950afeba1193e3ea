#include "stages/ingest/ingest_stage.h"

#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "formats/checked_file.h"
#include "formats/flight_log/flight_log.h"
#include "formats/image_file.h"
#include "formats/flight_log/track_csv.h"
#include "formats/stereo/calibration_check.h"
#include "formats/stereo/calibration_readers.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/stereo/image_io.h"
#include "formats/stereo/rectifier.h"
#include "formats/stereo/stereo_source.h"
#include "stages/ingest/flight_log_check.h"
#include "stages/ingest/time_alignment.h"
#include "survey/atomic_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

// The calibration the survey names, else the one the layout carries.
StereoCalibration LoadCalibration(const SurveyFile& survey, const StereoSource& source) {
  if (const auto path = survey.InputPath("calibration")) return ReadStereoCalibration(*path);
  if (source.calibration()) return *source.calibration();
  throw InputError(InputLocation::File(survey.path.string()),
                   "no calibration: the frames folder carries none, so set inputs.calibration.path");
}

void CheckFrameSize(const cv::Mat& image, const CameraIntrinsics& cam, const fs::path& path) {
  if (cam.width > 0 && (image.cols != cam.width || image.rows != cam.height))
    throw InputError(InputLocation::File(path.string()), fmt::format("image is {}x{}, calibration says {}x{}",
                                                                     image.cols, image.rows, cam.width, cam.height));
}

// A frame whose image file is gone is skipped like a corrupt one (the source lists it with a
// warning), so one lost file costs one frame, not the survey.
void RequireImageFiles(const FrameRecord& f) {
  for (const auto& [path, side] : {std::pair{&f.left, "left"}, std::pair{&f.right, "right"}})
    if (!fs::is_regular_file(*path))
      throw InputError(InputLocation::File(path->string()), fmt::format("{} image missing", side));
}

// ingest.json's list of the frames left out, by id, with the reason and the file at fault.
nlohmann::json SkippedFramesJson(const StageSummary& summary) { return summary.ToJson()["frames"]["skipped_frames"]; }

int64_t Seconds(double s) { return static_cast<int64_t>(std::llround(s * 1e9)); }

// The frame list downstream stages read: skipped frames are left out (ids keep their values);
// raw pairs point at their rectified images in the frame's folder.
std::vector<FrameRecord> UsableFrames(const StageContext& ctx, const std::vector<FrameRecord>& frames, bool raw) {
  std::vector<FrameRecord> good;
  for (auto f : frames) {
    const fs::path dir = ctx.FrameDir(f.id);
    if (fs::exists(dir / "skipped.json")) continue;
    if (raw) {
      f.left = dir / "left.png";
      f.right = dir / "right.png";
    }
    good.push_back(f);
  }
  return good;
}

// The frames as a run lists them; `run`'s up-front check lists them the same way, so whatever
// this tolerates (or rejects) the check does too.
StereoSource ListFrames(const SurveyFile& survey) {
  return OpenStereoSource(*survey.InputPath("frames"), survey.inputs["frames"].value("layout", std::string("auto")));
}

// Frame times (camera clock) of every listed frame: the flight-log checks see the same frames in
// `validate` and `run`, whichever images later turn out unreadable.
std::vector<int64_t> CameraTimes(const StereoSource& source) {
  std::vector<int64_t> times;
  for (const auto& f : source.frames()) times.push_back(f.t_ns);
  return times;
}

// Whether a problem already listed sits in `file` (a file the layout read is not reported twice).
bool HasErrorIn(const ProblemList& problems, const fs::path& file) {
  std::error_code ec;
  const fs::path target = fs::weakly_canonical(file, ec);
  for (const auto& p : problems.items())
    if (p.severity == InputProblem::Severity::kError && fs::weakly_canonical(p.where.path, ec) == target) return true;
  return false;
}

}  // namespace

void IngestOptions::Check() const {}

const OptionTable<IngestOptions>& IngestOptions::Table() {
  static const auto table =
      OptionTable<IngestOptions>()
          .Add("check_images", &IngestOptions::check_images, "decode every image up front to find corrupt frames")
          .Add("skip_bad_frames", &IngestOptions::skip_bad_frames,
               "skip and count unreadable frames instead of failing the stage")
          .Add("rectify_alpha", &IngestOptions::rectify_alpha,
               "rectification free scaling for raw pairs: 0 keeps only valid pixels, 1 keeps every raw pixel")
          .Min(0)
          .Max(1)
          .Add("estimate_clock_offset", &IngestOptions::estimate_clock_offset,
               "estimate the camera-log clock offset from the log's camera trigger events when it has them")
          .Add("max_log_gap_s", &IngestOptions::max_log_gap_s,
               "fixes further apart than this leave the frames between them without a prior", "s")
          .Above(0)
          .Add("max_speed_m_s", &IngestOptions::max_speed_m_s,
               "consecutive fixes implying a higher speed are reported as implausible jumps", "m/s")
          .Above(0)
          .Add("min_in_span_fraction", &IngestOptions::min_in_span_fraction,
               "fail when a smaller fraction of frames falls inside the flight log's time span (wrong log or offset)")
          .Min(0)
          .Max(1);
  return table;
}

StageInfo IngestStage::Info() {
  StageInfo info;
  info.name = "ingest";
  info.version = 2;  // 2: skipped frames listed in ingest.json; log coverage checked on every listed frame
  info.doc =
      "Lists stereo frames, checks and rectifies them, reads the flight log and gives each frame a "
      "time-aligned GNSS/attitude prior.";
  info.inputs = {kSurveyInputs};
  info.outputs = {"frames", "calibration", "priors"};
  info.published = {{"ingest.json", "ingest.json"}};
  info.per_frame = true;
  return info;
}

void IngestStage::Run(StageContext& ctx, const IngestOptions& o) const {
  const SurveyFile& survey = ctx.survey();
  const auto t0 = std::chrono::steady_clock::now();
  const fs::path frames_path = *survey.InputPath("frames");
  const StereoSource source = ListFrames(survey);
  for (const auto& w : source.warnings().items()) ctx.Warn(w.ToString());
  if (source.timestamps_synthesized()) ctx.Warn("frame times synthesized from the nominal frame rate");

  const StereoCalibration calib = LoadCalibration(survey, source);
  CheckStereoCalibration(calib, calib.source_path);
  const bool raw = !calib.rectified;
  std::optional<StereoRectifier> rectifier;
  if (raw) rectifier = StereoRectifier::LoadOrCreate(calib, ctx.out_dir() / "rectification.bin", o.rectify_alpha);
  const StereoCalibration rectified = raw ? rectifier->rectified() : calib;
  WriteCalibrationYaml(ctx.out_dir() / "calibration.yaml", rectified);

  std::vector<FrameRecord> frames;
  for (size_t i = 0; i < source.frames().size(); ++i) {
    const StereoFrame& f = source.frames()[i];
    frames.push_back({FrameId{static_cast<int64_t>(i)}, f.t_ns, f.left, f.right});
  }
  ctx.Time("list", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  ctx.frame_selection().RequireSelects(static_cast<int64_t>(frames.size()), survey.path.string());

  // Per frame: decode (and rectify) both images. Rectified pairs are written
  // into the frame's folder; already rectified sources are referenced in place.
  ctx.ForEachFrame(
      frames,
      [&](const FrameRecord& f, const fs::path& tmp) {
        FrameOutcome out;
        RequireImageFiles(f);
        if (!o.check_images && !raw) return out;
        const cv::Mat left = LoadImageRaw(f.left), right = LoadImageRaw(f.right);
        CheckFrameSize(left, calib.left, f.left);
        CheckFrameSize(right, calib.right, f.right);
        if (raw) {
          cv::Mat left_rect, right_rect;
          rectifier->Rectify(left, right, &left_rect, &right_rect);
          WriteImageFile(tmp / "left.png", left_rect);
          WriteImageFile(tmp / "right.png", right_rect);
        }
        out.counts["images_checked"] = 2;
        return out;
      },
      o.skip_bad_frames);

  const std::vector<FrameRecord> good = UsableFrames(ctx, frames, raw);
  WriteFrameIndex(ctx.out_dir() / "frames.csv", good);

  nlohmann::json report = {{"layout", ToString(source.layout())},
                           {"frames_folder", frames_path.string()},
                           {"frames_listed", frames.size()},
                           {"frames_usable", good.size()},
                           {"skipped_frames", SkippedFramesJson(ctx.summary())},
                           {"calibration",
                            {{"source", calib.source_path},
                             {"raw", raw},
                             {"fx_px", rectified.left.fx},
                             {"baseline_m", rectified.BaselineM()},
                             {"width", rectified.left.width},
                             {"height", rectified.left.height}}}};

  // Flight log: normalized track, clock offset, per-frame priors.
  std::vector<FramePrior> priors;
  if (const auto log_path = survey.InputPath("flight_log")) {
    const auto t1 = std::chrono::steady_clock::now();
    const auto& log_spec = survey.inputs["flight_log"];
    const FlightTrack track = ReadFlightLog(*log_path, log_spec.value("format", std::string("auto")));
    WriteStreamChecked(ctx.out_dir() / "track.csv", [&](std::ostream& out) { WriteTrackCsv(out, track); });
    // The checks `validate` makes, on the same frames: a log it rejects fails here the same way.
    ProblemList log_problems;
    const auto alignment = CheckFlightLog(track, *log_path, log_spec, CameraTimes(source), o, log_problems);
    for (const auto& p : log_problems.items()) {
      if (p.severity == InputProblem::Severity::kError) throw InputError(p.where, p.message);
      ctx.Warn("flight log: " + p.message);
    }
    const TrackFindings findings = CheckTrack(track, Seconds(o.max_log_gap_s), o.max_speed_m_s);
    const int64_t offset_ns = alignment->offset_ns;
    const nlohmann::json& offset_report = alignment->report;
    priors = InterpolatePriors(good, track, offset_ns, Seconds(o.max_log_gap_s));
    std::map<std::string, int> by_status;
    for (const auto& p : priors) ++by_status[ToString(p.status)];
    if (by_status["outside-span"] > 0)
      ctx.Warn(fmt::format("{} frame(s) lie outside the flight log's time span: no prior, not extrapolated",
                           by_status["outside-span"]));
    if (by_status["in-gap"] > 0)
      ctx.Warn(fmt::format("{} frame(s) fall in flight log gaps longer than {} s: no prior", by_status["in-gap"],
                           o.max_log_gap_s));
    report["flight_log"] = {{"path", log_path->string()},
                            {"format", track.format},
                            {"time_base", ToString(track.time_base)},
                            {"fixes", track.fixes.size()},
                            {"attitude_samples", track.attitude.size()},
                            {"camera_events", track.camera_events.size()},
                            {"altitude_reference", ToString(track.fixes.front().alt_ref)},
                            {"gaps", findings.gaps},
                            {"jumps", findings.jumps},
                            {"clock_offset", offset_report},
                            {"priors", by_status}};
    ctx.Count("frames_with_prior", by_status["ok"]);
    ctx.Time("flight_log", std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count());
  } else {
    for (const auto& f : good) priors.push_back({f.id, f.t_ns, f.t_ns});
    report["flight_log"] = nullptr;
  }
  WriteFramePriors(ctx.out_dir() / "frame_priors.csv", priors);
  ctx.Count("frames_usable", static_cast<double>(good.size()));
  WriteJsonAtomic(ctx.out_dir() / "ingest.json", report);
}

void IngestStage::ValidateInputs(const SurveyFile& survey, const IngestOptions& o, ValidationDepth depth,
                                 ProblemList& problems) const {
  const fs::path frames_path = *survey.InputPath("frames");
  const std::string layout = survey.inputs["frames"].value("layout", std::string("auto"));
  std::optional<StereoSource> source;
  try {
    // validate lists every listing problem; run's check stops where the run's own listing would.
    source = depth == ValidationDepth::kFull ? OpenStereoSource(frames_path, layout, &problems) : ListFrames(survey);
  } catch (const InputError& e) {
    problems.Add(e);
  }
  if (source) {
    const auto named = survey.InputPath("calibration");
    // The layout's own calibration file was read while listing; its problems are listed already.
    if (!named || !HasErrorIn(problems, *named)) {
      try {
        const StereoCalibration calib = LoadCalibration(survey, *source);
        CheckStereoCalibration(calib, calib.source_path);
      } catch (const InputError& e) {
        problems.Add(e);
      }
    }
    if (o.check_images && depth == ValidationDepth::kFull) ValidateStereoImages(*source, &problems, o.skip_bad_frames);
  }
  if (const auto log_path = survey.InputPath("flight_log")) {
    try {
      const auto& log_spec = survey.inputs["flight_log"];
      const FlightTrack track = ReadFlightLog(*log_path, log_spec.value("format", std::string("auto")));
      CheckFlightLog(track, *log_path, log_spec, source ? CameraTimes(*source) : std::vector<int64_t>{}, o, problems);
    } catch (const InputError& e) {
      problems.Add(e);
    }
  }
}

}  // namespace rs
