#include "formats/flight_log/flight_log.h"

#include <fmt/format.h>

#include <algorithm>
#include <fstream>

#include "formats/flight_log/dataflash/dataflash_track.h"
#include "formats/flight_log/dji_srt.h"
#include "formats/flight_log/flight_csv.h"
#include "formats/flight_log/gpx.h"
#include "formats/flight_log/kitti_oxts.h"
#include "formats/flight_log/track_csv.h"
#include "formats/flight_log/ulog/ulog_track.h"
#include "formats/input_error.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

std::string Head(const fs::path& path, size_t n) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open flight log");
  std::string head(n, '\0');
  in.read(head.data(), static_cast<std::streamsize>(n));
  head.resize(static_cast<size_t>(in.gcount()));
  return head;
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

}  // namespace

std::string DetectFlightLogFormat(const fs::path& path) {
  if (fs::is_directory(path)) {
    if (fs::exists(path / "timestamps.txt") && fs::is_directory(path / "data")) return "kitti-oxts";
    throw InputError(InputLocation::File(path.string()),
                     "a folder is only a flight log in the KITTI OXTS layout (data/ + timestamps.txt)");
  }
  const std::string head = Head(path, 4096);
  if (head.rfind(std::string("ULog\x01\x12\x35", 7), 0) == 0) return "px4-ulog";
  if (head.size() >= 3 && static_cast<unsigned char>(head[0]) == 0xA3 && static_cast<unsigned char>(head[1]) == 0x95)
    return "ardupilot-dataflash";
  const std::string lower = Lower(head);
  if (lower.find("<gpx") != std::string::npos) return "gpx";
  const std::string ext = Lower(path.extension().string());
  if (ext == ".srt") return "dji-srt";
  if (lower.rfind("# roadsurvey flight track", 0) == 0) return "csv";
  if (lower.find("time(millisecond)") != std::string::npos || lower.find("datetime(utc)") != std::string::npos)
    return "airdata-csv";
  if (ext == ".csv" || ext == ".txt") return "csv";
  throw InputError(InputLocation::File(path.string()),
                   "unrecognised flight log (expected PX4 ULog, ArduPilot DataFlash .bin, GPX, DJI .SRT, CSV "
                   "or a KITTI OXTS folder); name the format with inputs.flight_log.format");
}

FlightTrack ReadFlightLog(const fs::path& path, const std::string& format_in) {
  const std::string format = format_in == "auto" ? DetectFlightLogFormat(path) : format_in;
  if (format == "csv") {
    // Our own track CSV announces itself; anything else is a third-party CSV.
    return Lower(Head(path, 64)).rfind("# roadsurvey flight track", 0) == 0 ? ReadTrackCsv(path) : ReadFlightCsv(path);
  }
  if (format == "airdata-csv") return ReadFlightCsv(path);
  if (format == "gpx") return ReadGpx(path);
  if (format == "px4-ulog") return ReadUlogTrack(path);
  if (format == "ardupilot-dataflash") return ReadDataflashTrack(path);
  if (format == "dji-srt") return ReadDjiSrt(path);
  if (format == "kitti-oxts") return ReadKittiOxts(path);
  throw InputError(InputLocation::File(path.string()), fmt::format("unknown flight log format '{}'", format));
}

}  // namespace rs
