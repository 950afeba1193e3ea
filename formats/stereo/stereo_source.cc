#include "formats/stereo/stereo_source.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "formats/stereo/calibration_readers.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/stereo/image_io.h"

namespace rs {
namespace fs = std::filesystem;

namespace {

/// Routes problems: throw on the first error (ingest) or record everything (validate).
class Sink {
 public:
  explicit Sink(ProblemList* problems) : problems_(problems) {}
  void Error(InputLocation where, const std::string& msg) {
    if (!problems_) throw InputError(std::move(where), msg);
    problems_->Error(std::move(where), msg);
  }
  void Warning(InputLocation where, const std::string& msg) {
    warnings_.Warning(where, msg);
    if (problems_) problems_->Warning(std::move(where), msg);
  }
  /// Runs f; an InputError it throws becomes a recorded error. Returns false on error.
  template <typename F>
  bool Try(F&& f) {
    try {
      f();
      return true;
    } catch (const InputError& e) {
      Error(e.where(), e.message());
      return false;
    }
  }
  ProblemList TakeWarnings() { return std::move(warnings_); }

 private:
  ProblemList* problems_;
  ProblemList warnings_;
};

bool IsImageFile(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff";
}

std::vector<fs::path> ListImages(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && IsImageFile(e.path())) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

std::string Trim(std::string s) {
  while (!s.empty() && (s.back() == '\r' || s.back() == ' ' || s.back() == '\t')) s.pop_back();
  size_t i = s.find_first_not_of(" \t");
  return i == std::string::npos ? std::string() : s.substr(i);
}

bool ParseInt64(const std::string& s, int64_t* v) {
  if (s.empty()) return false;
  size_t pos = 0;
  try {
    *v = std::stoll(s, &pos);
  } catch (...) {
    return false;
  }
  return pos == s.size();
}

/// Decimal seconds ("0.103634", "1.036340e-01") to ns, rejecting non-finite and negative values.
bool ParseSecondsToNs(const std::string& s, int64_t* t_ns) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(v) || v < 0 || v > 9e9) return false;
  *t_ns = std::llround(v * 1e9);
  return true;
}

/// KITTI raw "2011-09-26 13:17:59.287203584" (taken as UTC) to ns since the Unix epoch.
bool ParseKittiDateTime(const std::string& s, int64_t* t_ns) {
  int y, mo, d, h, mi;
  char frac[32] = {0};
  int sec;
  if (std::sscanf(s.c_str(), "%d-%d-%d %d:%d:%d.%31[0-9]", &y, &mo, &d, &h, &mi, &sec, frac) < 6) return false;
  if (mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || sec > 60) return false;
  using namespace std::chrono;
  const year_month_day ymd{year{y}, month{static_cast<unsigned>(mo)}, day{static_cast<unsigned>(d)}};
  if (!ymd.ok()) return false;
  const int64_t days = sys_days{ymd}.time_since_epoch().count();
  std::string f = frac;
  f.resize(9, '0');  // nanoseconds
  const int64_t seconds = ((days * 24 + h) * 60 + mi) * 60 + sec;
  *t_ns = seconds * 1000000000 + std::stoll(f);
  return true;
}

/// Reads lines of a text file; the Sink gets an error when it cannot be opened.
bool ReadLines(const fs::path& p, std::vector<std::string>* lines, Sink* sink) {
  std::ifstream in(p);
  if (!in) {
    sink->Error(InputLocation::File(p.string()), "cannot open file");
    return false;
  }
  std::string l;
  while (std::getline(in, l)) lines->push_back(l);
  return true;
}

cv::Size FirstImageSize(const std::vector<StereoFrame>& frames, Sink* sink) {
  if (frames.empty()) return {};
  cv::Size size;
  sink->Try([&] { size = LoadImageRaw(frames.front().left).size(); });
  return size;
}

// A listed frame whose image file is missing stays listed: ingest skips it by id and reason,
// like a corrupt image, so one lost file costs one frame, not the survey.
void WarnMissingImages(const StereoFrame& f, const InputLocation& left_where, const InputLocation& right_where,
                       Sink* sink) {
  for (const auto& [p, w] : {std::pair{&f.left, &left_where}, std::pair{&f.right, &right_where}})
    if (!fs::is_regular_file(*p)) sink->Warning(*w, "image " + p->string() + " does not exist: the frame is skipped");
}

// ---- plain: left/<name>, right/<name>, timestamps.csv (filename,t_ns), calibration.yaml ----

StereoSource OpenPlain(const fs::path& root, Sink* sink) {
  const fs::path csv = root / "timestamps.csv";
  std::vector<StereoFrame> frames;
  std::vector<std::string> lines;
  for (const char* d : {"left", "right"})
    if (!fs::is_directory(root / d)) sink->Error(InputLocation::File((root / d).string()), "missing folder");
  std::set<std::string> listed;
  if (ReadLines(csv, &lines, sink)) {
    if (lines.empty() || Trim(lines[0]) != "filename,t_ns")
      sink->Error(InputLocation::Line(csv.string(), 1), "header must be 'filename,t_ns'");
    for (size_t i = 1; i < lines.size(); ++i) {
      const int64_t line_no = static_cast<int64_t>(i) + 1;
      const InputLocation where = InputLocation::Line(csv.string(), line_no);
      const std::string l = Trim(lines[i]);
      if (l.empty()) continue;
      const size_t comma = l.find(',');
      if (comma == std::string::npos || l.find(',', comma + 1) != std::string::npos) {
        sink->Error(where, "expected 2 fields 'filename,t_ns'");
        continue;
      }
      const std::string name = Trim(l.substr(0, comma));
      int64_t t_ns;
      if (!ParseInt64(Trim(l.substr(comma + 1)), &t_ns)) {
        sink->Error(where, "t_ns '" + Trim(l.substr(comma + 1)) + "' is not an integer (nanoseconds)");
        continue;
      }
      if (name.empty() || name.find('/') != std::string::npos || name.find('\\') != std::string::npos) {
        sink->Error(where, "filename '" + name + "' must be a bare file name");
        continue;
      }
      if (!listed.insert(name).second) {
        sink->Error(where, "filename '" + name + "' listed twice");
        continue;
      }
      StereoFrame f{t_ns, root / "left" / name, root / "right" / name, where};
      WarnMissingImages(f, where, where, sink);
      frames.push_back(std::move(f));
    }
  }
  // Images nobody listed are probably a mistake (a truncated timestamps.csv).
  for (const char* d : {"left", "right"}) {
    if (!fs::is_directory(root / d)) continue;
    int unlisted = 0;
    for (const fs::path& p : ListImages(root / d)) unlisted += listed.count(p.filename().string()) == 0;
    if (unlisted > 0)
      sink->Warning(InputLocation::File((root / d).string()),
                    std::to_string(unlisted) + " image(s) not listed in timestamps.csv");
  }
  if (fs::is_directory(root / "left") && fs::is_directory(root / "right")) {
    const size_t nl = ListImages(root / "left").size(), nr = ListImages(root / "right").size();
    if (nl != nr)
      sink->Warning(InputLocation::File(root.string()),
                    "left/ holds " + std::to_string(nl) + " images but right/ holds " + std::to_string(nr));
  }
  std::optional<StereoCalibration> calib;
  if (fs::exists(root / "calibration.yaml")) sink->Try([&] { calib = ReadCalibrationYaml(root / "calibration.yaml"); });
  return StereoSource(StereoLayout::kPlain, root, std::move(frames), std::move(calib), false, sink->TakeWarnings());
}

// ---- KITTI odometry: image_0/ image_1/ (or image_l/ image_r/), times.txt, calib.txt ----

StereoSource OpenKittiOdometry(const fs::path& root, Sink* sink) {
  fs::path ld = root / "image_0", rd = root / "image_1";
  if (!fs::is_directory(ld)) ld = root / "image_l", rd = root / "image_r";
  std::vector<StereoFrame> frames;
  const std::vector<fs::path> lefts = ListImages(ld);
  const size_t nr = fs::is_directory(rd) ? ListImages(rd).size() : 0;
  if (lefts.size() != nr)
    sink->Warning(InputLocation::File(root.string()), ld.filename().string() + "/ holds " +
                                                          std::to_string(lefts.size()) + " images but " +
                                                          rd.filename().string() + "/ holds " + std::to_string(nr));
  const fs::path times = root / "times.txt";
  std::vector<std::string> lines;
  const bool have_times = fs::exists(times);
  if (have_times) {
    ReadLines(times, &lines, sink);
    while (!lines.empty() && Trim(lines.back()).empty()) lines.pop_back();
    if (lines.size() != lefts.size())
      sink->Error(InputLocation::File(times.string()),
                  "holds " + std::to_string(lines.size()) + " times for " + std::to_string(lefts.size()) + " images");
  } else {
    sink->Warning(InputLocation::File(times.string()),
                  "absent: timestamps synthesized at KITTI's nominal 10 Hz (t = index * 100 ms)");
  }
  for (size_t i = 0; i < lefts.size(); ++i) {
    StereoFrame f{static_cast<int64_t>(i) * 100'000'000, lefts[i], rd / lefts[i].filename(),
                  InputLocation::File(lefts[i].string())};
    if (have_times) {
      if (i >= lines.size()) break;
      f.where = InputLocation::Line(times.string(), static_cast<int64_t>(i) + 1);
      if (!ParseSecondsToNs(Trim(lines[i]), &f.t_ns)) {
        sink->Error(f.where, "'" + Trim(lines[i]) + "' is not a time in seconds");
        continue;
      }
    }
    WarnMissingImages(f, f.where, InputLocation::File(f.right.string()), sink);
    frames.push_back(std::move(f));
  }
  std::optional<StereoCalibration> calib;
  if (fs::exists(root / "calib.txt")) {
    const cv::Size size = FirstImageSize(frames, sink);
    sink->Try([&] {
      std::ifstream in(root / "calib.txt");
      calib = ReadKittiOdometryCalib(in, (root / "calib.txt").string(), size.width, size.height);
    });
  } else {
    sink->Warning(InputLocation::File((root / "calib.txt").string()), "absent: no calibration in the layout");
  }
  return StereoSource(StereoLayout::kKittiOdometry, root, std::move(frames), std::move(calib), !have_times,
                      sink->TakeWarnings());
}

// ---- KITTI raw: <date>/<drive>/image_02/data/*.png, image_03/..., image_02/timestamps.txt,
//      <date>/calib_cam_to_cam.txt ----

StereoSource OpenKittiRaw(const fs::path& root, Sink* sink) {
  const fs::path ld = root / "image_02" / "data", rd = root / "image_03" / "data";
  const fs::path times = root / "image_02" / "timestamps.txt";
  std::vector<std::string> lines;
  ReadLines(times, &lines, sink);
  std::vector<StereoFrame> frames;
  const std::vector<fs::path> lefts = ListImages(ld);
  const size_t nr = fs::is_directory(rd) ? ListImages(rd).size() : 0;
  if (lefts.size() != nr)
    sink->Warning(InputLocation::File(root.string()), "image_02/data holds " + std::to_string(lefts.size()) +
                                                          " images but image_03/data holds " + std::to_string(nr));
  for (const fs::path& l : lefts) {
    int64_t index;
    if (!ParseInt64(l.stem().string(), &index) || index < 0) {
      sink->Error(InputLocation::File(l.string()), "file name is not a frame number");
      continue;
    }
    // Frame N's time is line N+1 of timestamps.txt (the file covers the whole drive).
    const InputLocation where = InputLocation::Line(times.string(), index + 1);
    if (index >= static_cast<int64_t>(lines.size())) {
      sink->Error(where, "no timestamp for " + l.filename().string());
      continue;
    }
    StereoFrame f{0, l, rd / l.filename(), where};
    if (!ParseKittiDateTime(Trim(lines[static_cast<size_t>(index)]), &f.t_ns)) {
      sink->Error(where, "'" + Trim(lines[static_cast<size_t>(index)]) + "' is not 'YYYY-MM-DD hh:mm:ss.fffffffff'");
      continue;
    }
    WarnMissingImages(f, f.where, InputLocation::File(f.right.string()), sink);
    frames.push_back(std::move(f));
  }
  std::optional<StereoCalibration> calib;
  const fs::path cc = root.parent_path() / "calib_cam_to_cam.txt";
  if (fs::exists(cc)) {
    const cv::Size size = FirstImageSize(frames, sink);
    sink->Try([&] {
      std::ifstream in(cc);
      StereoCalibration c = ReadKittiRawCamToCam(in, cc.string(), true);
      if (size.width > 0 && (size.width != c.left.width || size.height != c.left.height)) {
        // Not the rectified "_sync" size: the unrectified "_extract" images.
        std::ifstream in2(cc);
        c = ReadKittiRawCamToCam(in2, cc.string(), false);
        if (size.width != c.left.width || size.height != c.left.height)
          throw InputError(InputLocation::File(cc.string()), "image size " + std::to_string(size.width) + "x" +
                                                                 std::to_string(size.height) +
                                                                 " matches neither S_rect_02 nor S_02");
      }
      calib = c;
    });
  } else {
    sink->Warning(InputLocation::File(cc.string()), "absent: no calibration in the layout");
  }
  return StereoSource(StereoLayout::kKittiRaw, root, std::move(frames), std::move(calib), false, sink->TakeWarnings());
}

// ---- EuRoC / ASL: mav0/cam0/data.csv (#timestamp [ns],filename), cam0/data/, cam1/..., sensor.yaml ----

fs::path EurocMav0(const fs::path& root) { return fs::exists(root / "mav0") ? root / "mav0" : root; }

std::map<int64_t, std::pair<std::string, InputLocation>> ReadEurocCsv(const fs::path& csv, Sink* sink) {
  std::map<int64_t, std::pair<std::string, InputLocation>> out;
  std::vector<std::string> lines;
  ReadLines(csv, &lines, sink);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string l = Trim(lines[i]);
    if (l.empty() || l[0] == '#') continue;
    const InputLocation where = InputLocation::Line(csv.string(), static_cast<int64_t>(i) + 1);
    const size_t comma = l.find(',');
    int64_t t_ns;
    if (comma == std::string::npos || !ParseInt64(Trim(l.substr(0, comma)), &t_ns)) {
      sink->Error(where, "expected 'timestamp_ns,filename'");
      continue;
    }
    if (!out.emplace(t_ns, std::pair{Trim(l.substr(comma + 1)), where}).second)
      sink->Error(where, "duplicate timestamp " + std::to_string(t_ns));
  }
  return out;
}

StereoSource OpenEuroc(const fs::path& root, Sink* sink) {
  const fs::path mav0 = EurocMav0(root);
  const auto c0 = ReadEurocCsv(mav0 / "cam0" / "data.csv", sink);
  const auto c1 = ReadEurocCsv(mav0 / "cam1" / "data.csv", sink);
  std::vector<StereoFrame> frames;
  int unpaired_right = 0;
  for (const auto& [t, v] : c1) unpaired_right += c0.count(t) == 0;
  if (unpaired_right > 0)
    sink->Warning(InputLocation::File((mav0 / "cam1" / "data.csv").string()),
                  std::to_string(unpaired_right) + " timestamp(s) without a cam0 frame (left out)");
  for (const auto& [t, v] : c0) {
    auto it = c1.find(t);
    if (it == c1.end()) {
      sink->Warning(v.second, "no cam1 frame at " + std::to_string(t) + " (left out)");
      continue;
    }
    StereoFrame f{t, mav0 / "cam0" / "data" / v.first, mav0 / "cam1" / "data" / it->second.first, v.second};
    WarnMissingImages(f, v.second, it->second.second, sink);
    frames.push_back(std::move(f));
  }
  std::optional<StereoCalibration> calib;
  if (fs::exists(mav0 / "cam0" / "sensor.yaml") && fs::exists(mav0 / "cam1" / "sensor.yaml"))
    sink->Try([&] { calib = ReadEurocSensorPair(mav0 / "cam0" / "sensor.yaml", mav0 / "cam1" / "sensor.yaml"); });
  return StereoSource(StereoLayout::kEuroc, root, std::move(frames), std::move(calib), false, sink->TakeWarnings());
}

/// Duplicate and decreasing timestamps; offending frames are left out when recording.
void CheckMonotonic(std::vector<StereoFrame>* frames, Sink* sink) {
  std::vector<StereoFrame> kept;
  for (StereoFrame& f : *frames) {
    if (!kept.empty() && f.t_ns <= kept.back().t_ns) {
      sink->Error(f.where, std::string(f.t_ns == kept.back().t_ns ? "duplicate" : "non-monotonic") + " timestamp " +
                               std::to_string(f.t_ns) + " ns (previous frame " + kept.back().where.ToString() +
                               " has " + std::to_string(kept.back().t_ns) + ")");
      continue;
    }
    kept.push_back(std::move(f));
  }
  *frames = std::move(kept);
}

}  // namespace

std::string ToString(StereoLayout layout) {
  switch (layout) {
    case StereoLayout::kPlain: return "plain";
    case StereoLayout::kKittiOdometry: return "kitti-odometry";
    case StereoLayout::kKittiRaw: return "kitti-raw";
    case StereoLayout::kEuroc: return "euroc";
  }
  return "?";
}

StereoLayout ParseStereoLayout(const std::string& name, const std::string& option_name) {
  for (StereoLayout l :
       {StereoLayout::kPlain, StereoLayout::kKittiOdometry, StereoLayout::kKittiRaw, StereoLayout::kEuroc})
    if (ToString(l) == name) return l;
  throw InputError(InputLocation::File(option_name),
                   "unknown stereo layout '" + name + "' (auto, plain, kitti-odometry, kitti-raw, euroc)");
}

StereoLayout DetectLayout(const fs::path& folder) {
  const std::string p = folder.string();
  if (!fs::is_directory(folder)) throw InputError(InputLocation::File(p), "not a folder");
  if (fs::is_directory(folder / "left") && fs::is_directory(folder / "right") && fs::exists(folder / "timestamps.csv"))
    return StereoLayout::kPlain;
  if (fs::exists(EurocMav0(folder) / "cam0" / "data.csv")) return StereoLayout::kEuroc;
  if (fs::is_directory(folder / "image_02" / "data") && fs::is_directory(folder / "image_03" / "data"))
    return StereoLayout::kKittiRaw;
  if ((fs::is_directory(folder / "image_0") && fs::is_directory(folder / "image_1")) ||
      (fs::is_directory(folder / "image_l") && fs::is_directory(folder / "image_r")))
    return StereoLayout::kKittiOdometry;
  throw InputError(InputLocation::File(p),
                   "no known stereo layout (plain: left/ right/ timestamps.csv; KITTI odometry: image_0/ image_1/; "
                   "KITTI raw: image_02/data image_03/data; EuRoC: mav0/cam0/data.csv)");
}

StereoSource OpenStereoSource(const fs::path& folder, const std::string& layout, ProblemList* problems) {
  const StereoLayout l = layout == "auto" ? DetectLayout(folder) : ParseStereoLayout(layout);
  if (!fs::is_directory(folder)) throw InputError(InputLocation::File(folder.string()), "not a folder");
  Sink sink(problems);
  StereoSource s = [&] {
    switch (l) {
      case StereoLayout::kPlain: return OpenPlain(folder, &sink);
      case StereoLayout::kKittiOdometry: return OpenKittiOdometry(folder, &sink);
      case StereoLayout::kKittiRaw: return OpenKittiRaw(folder, &sink);
      case StereoLayout::kEuroc: return OpenEuroc(folder, &sink);
    }
    throw InputError(InputLocation::File(folder.string()), "unknown layout");
  }();
  std::vector<StereoFrame> frames = s.frames();
  CheckMonotonic(&frames, &sink);
  ProblemList warnings = s.warnings();
  if (frames.empty()) sink.Error(InputLocation::File(folder.string()), "no stereo frames found");
  return StereoSource(s.layout(), s.root(), std::move(frames), s.calibration(), s.timestamps_synthesized(),
                      std::move(warnings));
}

int ValidateStereoFolder(const fs::path& folder, const std::string& layout, ProblemList* problems) {
  StereoSource s = [&] {
    try {
      return OpenStereoSource(folder, layout, problems);
    } catch (const InputError& e) {  // no layout at all: nothing more to check
      problems->Add(e);
      return StereoSource(StereoLayout::kPlain, folder, {}, std::nullopt, false, {});
    }
  }();
  return ValidateStereoImages(s, problems);
}

int ValidateStereoImages(const StereoSource& s, ProblemList* problems, bool bad_frames_are_skipped) {
  const auto& calib = s.calibration();
  const auto report = [&](const InputLocation& where, const std::string& message) {
    if (bad_frames_are_skipped)
      problems->Warning(where, message + ": the frame will be skipped");
    else
      problems->Error(where, message);
  };
  int good = 0;
  for (const StereoFrame& f : s.frames()) {
    cv::Size sl, sr;
    bool ok = true;
    for (const auto& [p, size] : {std::pair{&f.left, &sl}, std::pair{&f.right, &sr}}) {
      if (!fs::exists(*p)) {  // the listing has reported it (an error, or a warning when it skips)
        ok = false;
        continue;
      }
      try {
        *size = LoadImageRaw(*p).size();
      } catch (const InputError& e) {
        report(e.where(), e.message());
        ok = false;
      }
    }
    if (!ok) continue;
    if (sl != sr) {
      report(f.where, "left " + std::to_string(sl.width) + "x" + std::to_string(sl.height) + " and right " +
                          std::to_string(sr.width) + "x" + std::to_string(sr.height) + " images differ in size");
      continue;
    }
    if (calib && calib->left.width > 0 && (calib->left.width != sl.width || calib->left.height != sl.height)) {
      report(f.where, "image size " + std::to_string(sl.width) + "x" + std::to_string(sl.height) +
                          " differs from the calibration's " + std::to_string(calib->left.width) + "x" +
                          std::to_string(calib->left.height) + " (" + calib->source_path + ")");
      continue;
    }
    ++good;
  }
  return good;
}

}  // namespace rs
