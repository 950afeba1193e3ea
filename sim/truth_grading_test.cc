#include "sim/truth_grading.h"

#include <gtest/gtest.h>

namespace rs::sim {
namespace {

TEST(PotholeSeverityAstm, Nominal) {
  // Rows: depth 13-25, 25-50, > 50 mm; columns: diameter 100-200, 200-450, 450-750 mm.
  EXPECT_EQ(PotholeSeverityAstm(0.020, 0.15), "L");
  EXPECT_EQ(PotholeSeverityAstm(0.020, 0.30), "L");
  EXPECT_EQ(PotholeSeverityAstm(0.020, 0.60), "M");
  EXPECT_EQ(PotholeSeverityAstm(0.040, 0.15), "L");
  EXPECT_EQ(PotholeSeverityAstm(0.040, 0.30), "M");
  EXPECT_EQ(PotholeSeverityAstm(0.040, 0.60), "H");
  EXPECT_EQ(PotholeSeverityAstm(0.080, 0.15), "M");
  EXPECT_EQ(PotholeSeverityAstm(0.080, 0.30), "M");
  EXPECT_EQ(PotholeSeverityAstm(0.080, 0.60), "H");
  EXPECT_EQ(PotholeSeverityAstm(0.020, 1.00), "M");  // wider than 750 mm
  EXPECT_EQ(PotholeSeverityAstm(0.030, 1.00), "H");
}

TEST(PotholeSeverityAstm, BelowThreshold) {
  EXPECT_EQ(PotholeSeverityAstm(0.010, 0.30), "");  // too shallow
  EXPECT_EQ(PotholeSeverityAstm(0.040, 0.05), "");  // too small
}

TEST(CrackSeverityFhwa, Nominal) {
  EXPECT_EQ(CrackSeverityFhwa(0.003), "L");
  EXPECT_EQ(CrackSeverityFhwa(0.006), "L");
  EXPECT_EQ(CrackSeverityFhwa(0.010), "M");
  EXPECT_EQ(CrackSeverityFhwa(0.020), "H");
}

}  // namespace
}  // namespace rs::sim
