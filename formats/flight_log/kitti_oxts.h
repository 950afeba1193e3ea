#pragma once
// KITTI raw OXTS GPS/IMU records: <drive>/oxts/data/NNNNNNNNNN.txt (one line of
// 30 numbers each, see oxts/dataformat.txt) and <drive>/oxts/timestamps.txt
// (one "YYYY-MM-DD HH:MM:SS.fffffffff" per record index).

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "formats/flight_log/flight_track.h"

namespace rs {

/// Reads KITTI timestamps.txt: one date-time per line, nanosecond fraction.
/// KITTI does not name the zone; the values are taken as UTC.
std::vector<int64_t> ReadKittiTimestamps(std::istream& in, const std::string& path);

/// Reads one OXTS record (30 whitespace-separated numbers) taken at `t_ns`
/// and appends its GnssFix (lat, lon, alt AMSL per the KITTI devkit, numsats,
/// fix type from posmode, pos_accuracy, ground speed from vn/ve) and its
/// AttitudeSample (KITTI roll/pitch/yaw, ENU/FLU, converted to FRD->NED).
void ReadKittiOxtsRecord(std::istream& in, const std::string& path, int64_t t_ns, FlightTrack* track);

/// Reads a KITTI raw `oxts` folder (data/*.txt + timestamps.txt). Record files
/// are indexed by their 10-digit names; a drive subset (e.g. 7 records of a
/// 474-line timestamps.txt) is fine. Throws rs::InputError naming the file
/// (and line) that is missing or malformed.
FlightTrack ReadKittiOxts(const std::filesystem::path& oxts_dir);

}  // namespace rs
