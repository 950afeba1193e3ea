#include "sim/truth_grading.h"

namespace rs::sim {

std::string PotholeSeverityAstm(double max_depth_m, double mean_diameter_m) {
  const double d_mm = max_depth_m * 1000, w_mm = mean_diameter_m * 1000;
  if (d_mm < 13 || w_mm < 100) return "";
  if (w_mm > 750) return d_mm <= 25 ? "M" : "H";
  const int col = w_mm <= 200 ? 0 : (w_mm <= 450 ? 1 : 2);
  static const char* kMatrix[3][3] = {{"L", "L", "M"}, {"L", "M", "H"}, {"M", "M", "H"}};
  const int row = d_mm <= 25 ? 0 : (d_mm <= 50 ? 1 : 2);
  return kMatrix[row][col];
}

std::string CrackSeverityFhwa(double width_m) {
  const double w_mm = width_m * 1000;
  if (w_mm <= 6) return "L";
  if (w_mm <= 19) return "M";
  return "H";
}

}  // namespace rs::sim
