#include "stages/damage_map/map_observation.h"

#include <cmath>

namespace rs {

std::vector<MapObservation> PlaceDetections(const FrameDetections& frame, const CameraToEnu& to_enu, int width,
                                            int height, int border_px) {
  std::vector<MapObservation> out;
  for (const DamageDetection& d : frame.detections) {
    if (d.outline_cam.size() < 3) continue;  // no outline on the road: nothing to place
    MapObservation o;
    o.frame = frame.frame;
    o.detection = d;
    for (const auto& p : d.outline_cam) o.outline_enu.push_back(to_enu(p));
    for (const auto& px : d.outline_px)
      if (px.x() <= border_px || px.y() <= border_px || px.x() >= width - 1 - border_px ||
          px.y() >= height - 1 - border_px)
        o.complete = false;
    out.push_back(std::move(o));
  }
  return out;
}

Eigen::Vector2d RingCentroid(const std::vector<Eigen::Vector3d>& ring) {
  double a = 0;
  Eigen::Vector2d c = Eigen::Vector2d::Zero(), mean = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < ring.size(); ++i) {
    const Eigen::Vector2d p = ring[i].head<2>(), q = ring[(i + 1) % ring.size()].head<2>();
    const double cross = p.x() * q.y() - q.x() * p.y();
    a += cross;
    c += (p + q) * cross;
    mean += p;
  }
  if (ring.empty()) return mean;
  if (std::abs(a) < 1e-12) return mean / static_cast<double>(ring.size());
  return c / (3 * a);
}

}  // namespace rs
