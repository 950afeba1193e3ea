#include "stages/slam/bundle_adjust_solver.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace rs {
namespace {

using Mat63 = Eigen::Matrix<double, 6, 3>;
using Mat36 = Eigen::Matrix<double, 3, 6, Eigen::RowMajor>;
using Mat33r = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
using Mat66 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

// Huber rho(s) of a squared norm s, and rho'(s) (the IRLS weight; Ceres' corrector reduces to it for
// Huber, whose rho'' <= 0).
double Rho(double s, double d) { return s <= d * d ? s : 2 * d * std::sqrt(s) - d * d; }
double Rho1(double s, double d) { return s <= d * d ? 1.0 : d / std::sqrt(s); }

// Gauss-Newton blocks at the current estimate (everything the damped step needs, for any damping).
struct Linearization {
  std::vector<Mat66> U;             // per free pose: sum w Jc^T Jc
  std::vector<Vec6> gc;             // per free pose: sum w Jc^T r
  std::vector<Eigen::Matrix3d> V;   // per point
  std::vector<Eigen::Vector3d> gp;  // per point
  std::vector<Mat63> W;             // per observation: w Jc^T Jp (zero when its pose is fixed)
};

class Solver {
 public:
  explicit Solver(SmallBundleProblem* p) : p_(*p) {
    slot_.assign(p_.poses.size(), -1);
    for (size_t k = 0; k < p_.poses.size(); ++k)
      if (!p_.pose_fixed[k]) slot_[k] = free_++;
    // Observations grouped by point, in their given order within a point.
    order_.resize(p_.observations.size());
    first_.assign(p_.points.size() + 1, 0);
    for (const auto& o : p_.observations) ++first_[o.point + 1];
    for (size_t i = 0; i < p_.points.size(); ++i) first_[i + 1] += first_[i];
    std::vector<int> fill(first_.begin(), first_.end() - 1);
    for (size_t i = 0; i < p_.observations.size(); ++i) order_[fill[p_.observations[i].point]++] = static_cast<int>(i);
  }

  double Cost() const {
    const std::vector<PoseRotation> rotations = Rotations();
    double c = 0;
    for (const auto& o : p_.observations) {
      double r[3];
      EvaluateReprojection(o.r, rotations[o.pose], p_.poses[o.pose].data() + 3, p_.points[o.point].data(), r, nullptr,
                           nullptr);
      c += Rho(r[0] * r[0] + r[1] * r[1] + r[2] * r[2], o.huber);
    }
    return 0.5 * c;
  }

  void Linearize(Linearization* L) const {
    L->U.assign(free_, Mat66::Zero());
    L->gc.assign(free_, Vec6::Zero());
    L->V.assign(p_.points.size(), Eigen::Matrix3d::Zero());
    L->gp.assign(p_.points.size(), Eigen::Vector3d::Zero());
    L->W.resize(p_.observations.size());
    const std::vector<PoseRotation> rotations = Rotations();
    for (size_t i = 0; i < p_.observations.size(); ++i) {
      const auto& o = p_.observations[i];
      Eigen::Vector3d r;
      Mat36 Jc;
      Mat33r Jp;
      EvaluateReprojection(o.r, rotations[o.pose], p_.poses[o.pose].data() + 3, p_.points[o.point].data(), r.data(),
                           Jc.data(), Jp.data());
      const double w = Rho1(r.squaredNorm(), o.huber);
      L->V[o.point].noalias() += w * Jp.transpose() * Jp;
      L->gp[o.point].noalias() += w * Jp.transpose() * r;
      const int c = slot_[o.pose];
      if (c < 0) {
        L->W[i].setZero();
        continue;
      }
      L->U[c].noalias() += w * Jc.transpose() * Jc;
      L->gc[c].noalias() += w * Jc.transpose() * r;
      L->W[i].noalias() = w * Jc.transpose() * Jp;
    }
  }

  // Solves (H + mu D) delta = -g by the Schur complement on the points (D = diag(H), clamped as
  // Ceres' min/max_lm_diagonal). Returns false if the reduced system is not positive definite;
  // else the step and the model's decrease 0.5 (-g.delta + mu delta^T D delta).
  bool Step(const Linearization& L, double mu, Eigen::VectorXd* dc, std::vector<Eigen::Vector3d>* dp,
            double* model_decrease) const {
    auto damp = [mu](double h) { return mu * std::clamp(h, 1e-6, 1e32); };
    const int n = 6 * free_;
    Eigen::MatrixXd S = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd b(n);
    for (int c = 0; c < free_; ++c) {
      S.block<6, 6>(6 * c, 6 * c) = L.U[c];
      for (int d = 0; d < 6; ++d) S(6 * c + d, 6 * c + d) += damp(L.U[c](d, d));
      b.segment<6>(6 * c) = -L.gc[c];
    }
    std::vector<Eigen::Matrix3d> Vinv(p_.points.size());
    std::vector<Mat63> Y(p_.observations.size());
    for (size_t q = 0; q < p_.points.size(); ++q) {
      Eigen::Matrix3d V = L.V[q];
      for (int d = 0; d < 3; ++d) V(d, d) += damp(L.V[q](d, d));
      Vinv[q] = V.inverse();
      if (!Vinv[q].allFinite()) return false;
      for (int a = first_[q]; a < first_[q + 1]; ++a) {
        const int i = order_[a], ci = slot_[p_.observations[i].pose];
        if (ci < 0) continue;
        Y[i].noalias() = L.W[i] * Vinv[q];
        b.segment<6>(6 * ci).noalias() += Y[i] * L.gp[q];
        for (int e = a; e < first_[q + 1]; ++e) {
          const int j = order_[e], cj = slot_[p_.observations[j].pose];
          if (cj < 0) continue;
          const Mat66 block = Y[i] * L.W[j].transpose();
          S.block<6, 6>(6 * ci, 6 * cj) -= block;
          if (cj != ci) S.block<6, 6>(6 * cj, 6 * ci) -= block.transpose();
        }
      }
    }
    if (n > 0) {
      const Eigen::LLT<Eigen::MatrixXd> llt(S);
      if (llt.info() != Eigen::Success) return false;
      *dc = llt.solve(b);
      if (!dc->allFinite()) return false;
    } else {
      dc->resize(0);
    }
    dp->resize(p_.points.size());
    double g_dot = 0, d_dot = 0;  // g . delta and delta^T D delta
    for (int c = 0; c < free_; ++c) {
      const Vec6 x = dc->segment<6>(6 * c);
      g_dot += L.gc[c].dot(x);
      for (int d = 0; d < 6; ++d) d_dot += damp(L.U[c](d, d)) * x(d) * x(d);
    }
    for (size_t q = 0; q < p_.points.size(); ++q) {
      Eigen::Vector3d rhs = -L.gp[q];
      for (int a = first_[q]; a < first_[q + 1]; ++a) {
        const int i = order_[a], ci = slot_[p_.observations[i].pose];
        if (ci >= 0) rhs.noalias() -= L.W[i].transpose() * dc->segment<6>(6 * ci);
      }
      (*dp)[q] = Vinv[q] * rhs;
      g_dot += L.gp[q].dot((*dp)[q]);
      for (int d = 0; d < 3; ++d) d_dot += damp(L.V[q](d, d)) * (*dp)[q](d) * (*dp)[q](d);
    }
    *model_decrease = 0.5 * (-g_dot + d_dot);
    return std::isfinite(*model_decrease);
  }

  void Apply(const Eigen::VectorXd& dc, const std::vector<Eigen::Vector3d>& dp) {
    for (size_t k = 0; k < p_.poses.size(); ++k)
      if (slot_[k] >= 0)
        for (int d = 0; d < 6; ++d) p_.poses[k][d] += dc(6 * slot_[k] + d);
    for (size_t q = 0; q < p_.points.size(); ++q)
      for (int d = 0; d < 3; ++d) p_.points[q][d] += dp[q](d);
  }

  double StepNorm2(const Eigen::VectorXd& dc, const std::vector<Eigen::Vector3d>& dp) const {
    double s = dc.squaredNorm();
    for (const auto& v : dp) s += v.squaredNorm();
    return s;
  }
  double ParamNorm2() const {
    double s = 0;
    for (size_t k = 0; k < p_.poses.size(); ++k)
      if (slot_[k] >= 0)
        for (double v : p_.poses[k]) s += v * v;
    for (const auto& x : p_.points)
      for (double v : x) s += v * v;
    return s;
  }

 private:
  std::vector<PoseRotation> Rotations() const {
    std::vector<PoseRotation> rotations;
    rotations.reserve(p_.poses.size());
    for (const auto& pose : p_.poses) rotations.emplace_back(pose.data());
    return rotations;
  }

  SmallBundleProblem& p_;
  std::vector<int> slot_;  // pose -> free pose index, -1 fixed
  int free_ = 0;
  std::vector<int> order_;  // observation indices grouped by point
  std::vector<int> first_;  // point q's observations: order_[first_[q] .. first_[q+1])
};

}  // namespace

SmallBundleSummary SolveSmallBundle(SmallBundleProblem* problem, int max_iterations) {
  SmallBundleSummary summary;
  if (problem->observations.empty()) return summary;
  Solver solver(problem);
  double cost = solver.Cost();
  summary.initial_cost = summary.final_cost = cost;
  // Ceres' defaults: initial trust region 1e4 (mu = 1e-4), radius / max(1/3, 1 - (2 rho - 1)^3) after a
  // success, radius / nu (nu doubling) after a failure; accept when rho > 1e-3; stop when the cost
  // changes by < 1e-6 of itself or the step by < 1e-8 of the parameters.
  double mu = 1e-4, nu = 2;
  Linearization L;
  solver.Linearize(&L);
  Eigen::VectorXd dc;
  std::vector<Eigen::Vector3d> dp;
  while (summary.iterations < max_iterations) {
    ++summary.iterations;
    double model = 0;
    if (!solver.Step(L, mu, &dc, &dp, &model) || model <= 0) {
      mu *= nu;
      nu *= 2;
      if (mu > 1e32) break;
      continue;
    }
    if (solver.StepNorm2(dc, dp) <= 1e-16 * (solver.ParamNorm2() + 1e-16)) break;
    const std::vector<std::array<double, 6>> poses = problem->poses;
    const std::vector<std::array<double, 3>> points = problem->points;
    solver.Apply(dc, dp);
    const double new_cost = solver.Cost();
    const double rho = (cost - new_cost) / model;
    if (!std::isfinite(new_cost) || rho <= 1e-3) {
      problem->poses = poses;  // exactly the previous estimate
      problem->points = points;
      mu *= nu;
      nu *= 2;
      if (mu > 1e32) break;
      continue;
    }
    ++summary.successful;
    const double change = cost - new_cost;
    cost = new_cost;
    mu = std::max(1e-16, mu * std::max(1.0 / 3.0, 1.0 - std::pow(2 * rho - 1, 3)));
    nu = 2;
    if (change < 1e-6 * cost) break;
    solver.Linearize(&L);
  }
  summary.final_cost = cost;
  return summary;
}

}  // namespace rs
