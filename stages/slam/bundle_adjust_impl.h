#pragma once
// Templated residual bodies of bundle_adjust.h (kept apart so the declarations stay readable).

#include <ceres/rotation.h>

namespace rs {

template <typename T>
bool ReprojectionResidual::operator()(const T* pose, const T* point, T* residual) const {
  T pc[3];
  ceres::AngleAxisRotatePoint(pose, point, pc);
  pc[0] += pose[3];
  pc[1] += pose[4];
  pc[2] += pose[5];
  const T iz = T(1.0) / pc[2];
  residual[0] = (T(fx) * pc[0] * iz + T(cx) - T(u)) * T(sqrt_info);
  residual[1] = (T(fy) * pc[1] * iz + T(cy) - T(v)) * T(sqrt_info);
  if (u_right >= 0) {
    residual[2] = (T(fx) * (pc[0] - T(baseline_m)) * iz + T(cx) - T(u_right)) * T(sqrt_info);
  } else {
    residual[2] = T(0.0);
  }
  return true;
}

template <typename T>
bool RelativePoseResidual::operator()(const T* pose_a, const T* pose_b, T* residual) const {
  // T_a_b(est) = T_world_a^-1 * T_world_b; error = T_a_b(meas)^-1 * T_a_b(est).
  T q_a[4], q_b[4];
  ceres::AngleAxisToQuaternion(pose_a, q_a);
  ceres::AngleAxisToQuaternion(pose_b, q_b);
  const T q_a_inv[4] = {q_a[0], -q_a[1], -q_a[2], -q_a[3]};
  T q_ab[4];
  ceres::QuaternionProduct(q_a_inv, q_b, q_ab);
  const T dt[3] = {pose_b[3] - pose_a[3], pose_b[4] - pose_a[4], pose_b[5] - pose_a[5]};
  T t_ab[3];
  ceres::QuaternionRotatePoint(q_a_inv, dt, t_ab);
  const T q_meas_inv[4] = {T(q_a_b.w()), T(-q_a_b.x()), T(-q_a_b.y()), T(-q_a_b.z())};
  T q_err[4];
  ceres::QuaternionProduct(q_meas_inv, q_ab, q_err);
  T aa_err[3];
  ceres::QuaternionToAngleAxis(q_err, aa_err);
  const T dtm[3] = {t_ab[0] - T(t_a_b.x()), t_ab[1] - T(t_a_b.y()), t_ab[2] - T(t_a_b.z())};
  T t_err[3];
  ceres::QuaternionRotatePoint(q_meas_inv, dtm, t_err);
  for (int i = 0; i < 3; ++i) {
    residual[i] = aa_err[i] * T(weight_rotation);
    residual[3 + i] = t_err[i] * T(weight_translation);
  }
  return true;
}

}  // namespace rs
