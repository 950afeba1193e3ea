#include "stages/damage/grade/severity.h"

#include <gtest/gtest.h>

namespace rs {
namespace {

using L = SeverityLevel;

// ASTM D6433 matrix (MISSION.md): rows depth 13–25, 25–50, > 50 mm; columns diameter
// 100–200, 200–450, 450–750 mm.
TEST(GradeAstmPothole, Nominal) {
  const SeverityOptions o;
  const double depth[3] = {0.020, 0.040, 0.060}, diam[3] = {0.150, 0.300, 0.600};
  const L table[3][3] = {
      {L::kLow, L::kLow, L::kMedium}, {L::kLow, L::kMedium, L::kHigh}, {L::kMedium, L::kMedium, L::kHigh}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const SeverityGrade g = GradeAstmPothole(depth[i], diam[j], 0.1, o);
      EXPECT_EQ(g.level, table[i][j]) << i << "," << j << ": " << g.rule;
      EXPECT_EQ(g.equivalent_count, 1);
      EXPECT_NE(g.rule.find("ASTM D6433"), std::string::npos);
    }
  // Bin edges are inclusive on the upper side: 25 mm is the low row, 200 mm the first column.
  EXPECT_EQ(GradeAstmPothole(0.025, 0.200, 0.03, o).level, L::kLow);
  EXPECT_EQ(GradeAstmPothole(0.0251, 0.451, 0.2, o).level, L::kHigh);
}

TEST(GradeAstmPothole, WiderThanTable) {
  const SeverityOptions o;
  const SeverityGrade shallow = GradeAstmPothole(0.020, 0.9, 1.25, o);
  EXPECT_EQ(shallow.level, L::kMedium);
  EXPECT_DOUBLE_EQ(shallow.equivalent_count, 2.5);  // 1.25 m² / 0.5 m²
  EXPECT_EQ(GradeAstmPothole(0.030, 0.9, 1.0, o).level, L::kHigh);
}

TEST(GradeAstmPothole, BelowTable) {
  const SeverityOptions o;
  EXPECT_EQ(GradeAstmPothole(0.010, 0.300, 0.07, o).level, L::kNone);   // too shallow
  EXPECT_EQ(GradeAstmPothole(0.040, 0.080, 0.005, o).level, L::kNone);  // too small
  EXPECT_EQ(GradeAstmPothole(kUnknown, 0.3, 0.07, o).level, L::kNone);
}

TEST(GradeFhwa, Nominal) {
  const SeverityOptions o;
  EXPECT_EQ(GradeFhwaPothole(0.020, 0.2, o).level, L::kLow);
  EXPECT_EQ(GradeFhwaPothole(0.025, 0.2, o).level, L::kLow);
  EXPECT_EQ(GradeFhwaPothole(0.040, 0.2, o).level, L::kMedium);
  EXPECT_EQ(GradeFhwaPothole(0.051, 0.2, o).level, L::kHigh);
  EXPECT_EQ(GradeFhwaPothole(0.060, 0.14, o).level, L::kNone);  // < 150 mm: not a pothole
  EXPECT_EQ(GradeFhwaCrack(0.004, o).level, L::kLow);
  EXPECT_EQ(GradeFhwaCrack(0.006, o).level, L::kLow);
  EXPECT_EQ(GradeFhwaCrack(0.012, o).level, L::kMedium);
  EXPECT_EQ(GradeFhwaCrack(0.020, o).level, L::kHigh);
}

TEST(GradeInstance, Intervention) {
  SeverityOptions o;
  DamageInstance d;
  d.type = DamageType::kPothole;
  d.max_depth_m = 0.045, d.max_diameter_m = 0.35, d.equivalent_diameter_m = 0.3, d.area_m2 = 0.07;
  GradeInstance(d, o);
  EXPECT_TRUE(d.intervention) << d.intervention_rule;
  EXPECT_EQ(d.astm.level, L::kMedium);
  EXPECT_EQ(d.fhwa.level, L::kMedium);
  d.max_diameter_m = 0.25;  // narrower than 300 mm
  GradeInstance(d, o);
  EXPECT_FALSE(d.intervention);
  o.intervention_width_m = 0.2;  // configurable
  GradeInstance(d, o);
  EXPECT_TRUE(d.intervention);
  DamageInstance c;
  c.type = DamageType::kCrack;
  c.mean_width_m = 0.008, c.max_width_m = 0.021;
  GradeInstance(c, o);
  EXPECT_EQ(c.fhwa.level, L::kMedium);
  EXPECT_TRUE(c.intervention);
  EXPECT_EQ(c.astm.level, L::kNone);
}

TEST(SeverityOptions, BadTable) {
  SeverityOptions o;
  o.astm_depth_mid_m = 0.01;
  EXPECT_THROW(o.Check(), OptionError);
}

}  // namespace
}  // namespace rs
