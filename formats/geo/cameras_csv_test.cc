#include "formats/geo/cameras_csv.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "formats/input_error.h"

namespace rs {
namespace {

namespace fs = std::filesystem;

constexpr const char* kHeader =
    "frame,t_ns,easting_m,northing_m,height_m,lat_deg,lon_deg,h_ellipsoid_m,roll_deg,pitch_deg,yaw_deg,status\n";

fs::path Write(const std::string& name, const std::string& text) {
  const fs::path dir = fs::temp_directory_path() / "rs_cameras_csv_test";
  fs::create_directories(dir);
  std::ofstream(dir / name) << text;
  return dir / name;
}

TEST(CamerasCsv, PositionsAttitudesAndSkippedRows) {
  const fs::path p = Write("ok.csv", std::string(kHeader) +
                                         "0,100,500000.5,5100000.25,301.5,46.05,14.5,350.1,1.5,-2.25,181,visual\n"
                                         "1,200,500001,5100001,302,46.06,14.6,351,,,,gnss-only\n"
                                         "2,300,,,,,,,,,,skipped\n");
  const std::vector<CameraRow> rows = ReadCamerasCsv(p);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].frame, 0);
  EXPECT_EQ(rows[0].t_ns, 100);
  EXPECT_EQ(rows[0].status, "visual");
  ASSERT_TRUE(rows[0].crs);
  EXPECT_DOUBLE_EQ(rows[0].crs->y(), 5100000.25);
  EXPECT_DOUBLE_EQ(rows[0].h_ellipsoid_m, 350.1);
  ASSERT_TRUE(rows[0].rpy_deg);
  EXPECT_DOUBLE_EQ(rows[0].rpy_deg->x(), 1.5);
  EXPECT_DOUBLE_EQ(rows[0].rpy_deg->y(), -2.25);
  EXPECT_DOUBLE_EQ(rows[0].rpy_deg->z(), 181);
  EXPECT_TRUE(rows[1].crs);
  EXPECT_FALSE(rows[1].rpy_deg);
  EXPECT_EQ(rows[2].status, "skipped");
  EXPECT_FALSE(rows[2].crs);
  EXPECT_FALSE(rows[2].rpy_deg);
}

TEST(CamerasCsv, BadAttitudeNamesLineColumnAndField) {
  const fs::path p = Write("bad.csv", std::string(kHeader) + "0,100,1,2,3,46,14,300,1,x2,3,visual\n");
  try {
    ReadCamerasCsv(p);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 2);
    EXPECT_EQ(e.where().column, 25);
    EXPECT_NE(std::string(e.what()).find("pitch_deg"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rs
