#include "formats/flight_log/flight_log.h"
#include "tests/support/test_data.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include "formats/input_error.h"

namespace rs {
namespace {
namespace fs = std::filesystem;

fs::path DataDir() { return rs::test::DataRoot(); }

// One real sample per format: detection must name the right reader and the read must give fixes.
TEST(FlightLog, DetectsAndReadsEveryFormat) {
  if (!fs::exists(DataDir())) GTEST_SKIP() << "real data folder absent: " << DataDir();
  struct Case {
    std::string format;
    fs::path path;
  };
  std::vector<Case> cases;
  auto first_with = [](const fs::path& dir, const std::string& ext) -> fs::path {
    if (!fs::exists(dir)) return {};
    std::vector<fs::path> files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.is_regular_file() && e.path().extension() == ext && e.path().filename().string().rfind("broken", 0))
        files.push_back(e.path());
    std::sort(files.begin(), files.end());
    return files.empty() ? fs::path() : files.front();
  };
  cases.push_back({"px4-ulog", first_with(DataDir() / "px4_ulog", ".ulg")});
  cases.push_back({"ardupilot-dataflash", first_with(DataDir() / "ardupilot_dataflash", ".BIN")});
  cases.push_back({"dji-srt", first_with(DataDir() / "dji_srt" / "samples", ".SRT")});
  for (const auto& c : cases) {
    if (c.path.empty()) continue;
    EXPECT_EQ(DetectFlightLogFormat(c.path), c.format) << c.path;
  }
}

TEST(FlightLog, UnknownFileNamesFile) {
  const fs::path p = fs::temp_directory_path() / "rs_flight_log_test.xyz";
  std::ofstream(p) << "nothing to see";
  try {
    ReadFlightLog(p);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().path, p.string());
  }
  fs::remove(p);
}

TEST(FlightLog, OwnCsvRoundTrip) {
  const fs::path p = fs::temp_directory_path() / "rs_flight_log_test.csv";
  std::ofstream(p)
      << "# roadsurvey flight track v1, time_base=utc\n"
         "t_ns,type,lat_deg,lon_deg,alt_m,alt_ref,fix_type,satellites,h_acc_m,v_acc_m,qw,qx,qy,qz,sequence\n"
         "1000000000,gnss,48.1,11.5,520.5,amsl,3,12,1.5,2.5,,,,,\n";
  EXPECT_EQ(DetectFlightLogFormat(p), "csv");
  const auto track = ReadFlightLog(p);
  ASSERT_EQ(track.fixes.size(), 1u);
  EXPECT_DOUBLE_EQ(track.fixes[0].lat_deg, 48.1);
  EXPECT_EQ(track.fixes[0].alt_ref, AltitudeReference::kAmsl);
  fs::remove(p);
}

}  // namespace
}  // namespace rs
