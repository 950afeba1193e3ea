#include "stages/damage_map/view_coverage.h"

#include <cmath>

namespace rs {

bool InView(const ExaminedView& view, const RectifiedStereo& camera, const Eigen::Vector3d& p_enu, int border_px) {
  const Eigen::Vector3d p = view.camera_from_enu * p_enu;
  if (!(p.z() > 0) || p.z() > view.analysed_range_m) return false;
  const double u = camera.f_px * p.x() / p.z() + camera.cx_px, v = camera.f_px * p.y() / p.z() + camera.cy_px;
  return u >= border_px && v >= border_px && u <= camera.width - 1 - border_px && v <= camera.height - 1 - border_px;
}

std::vector<int64_t> FramesInView(const std::vector<ExaminedView>& views, const RectifiedStereo& camera,
                                  const Eigen::Vector3d& p_enu, int border_px) {
  std::vector<int64_t> frames;
  for (const ExaminedView& v : views)
    if (InView(v, camera, p_enu, border_px)) frames.push_back(v.frame);
  return frames;
}

Eigen::Vector3d PolylineMidpoint(const std::vector<Eigen::Vector3d>& line) {
  if (line.empty()) return Eigen::Vector3d::Constant(NAN);
  double length = 0;
  for (size_t i = 1; i < line.size(); ++i) length += (line[i] - line[i - 1]).norm();
  double left = length / 2;
  for (size_t i = 1; i < line.size(); ++i) {
    const double step = (line[i] - line[i - 1]).norm();
    if (step >= left && step > 0) return line[i - 1] + (line[i] - line[i - 1]) * (left / step);
    left -= step;
  }
  return line.front();
}

}  // namespace rs
