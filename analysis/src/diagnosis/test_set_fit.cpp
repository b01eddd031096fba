// A test set's diagnosis as one model across its planes (test_set.hpp, docs/diagnosis.md "Test
// sets"): each plane is diagnosed on its own first (its nonlinear state: the play's take-up,
// the spike decays, the cyclic pitches, the lag mismatch), then the planes' normal equations at
// that state are stacked with each axis's backlash, spike height, scale and following lag as
// one unknown shared by every plane the axis is in, and solved once.
#include <algorithm>
#include <cmath>

#include "circtest/analysis/test_set.hpp"
#include "stages.hpp"

namespace circtest {

namespace {

using namespace diagnosis_detail;

// The per-axis unknowns the planes share.
enum Shared { kBacklash = 0, kSpike = 1, kScale = 2, kLag = 3, kSharedCount = 4 };

// Which per-axis terms are shared beyond backlash and spike height (which always are): the
// scales when a plane gives both the difference and the mean of its axes' scales, the
// following lags when a plane gives both its lag mismatch and its mean lag (commanded columns).
struct Sharing {
  bool scale = false;
  bool lag = false;
};

// One part of a plane column's coefficient: factor times shared unknown `param` of the plane's
// axis `ax` (0 the plane's first axis, 1 its second).
struct Part {
  int param;
  int ax;
  double factor;
};

// The shared unknowns a plane column's coefficient is made of; none for a column of the plane's
// own (centre, radius, squareness, cyclic terms). A backlash column of an axis that does not
// reverse in the plane is a shift between the directions there, the plane's own. The servo
// mismatch column is lag_A - lag_B, the scale mismatch column s_A - s_B less the servo's
// cos 2theta part w^2 lag (lag_A - lag_B); each the plane's own when not shared.
std::vector<Part> shared_parts(const PlaneFit& pl, Kind k, Sharing sh) {
  switch (k) {
    case Kind::backlash_a:
      if (pl.samples.reversal_a) return {{kBacklash, 0, 1.0}};
      break;
    case Kind::backlash_b:
      if (pl.samples.reversal_b) return {{kBacklash, 1, 1.0}};
      break;
    case Kind::spike_a:
      return {{kSpike, 0, 1.0}};
    case Kind::spike_b:
      return {{kSpike, 1, 1.0}};
    case Kind::scale_mismatch:
      if (sh.scale && sh.lag && pl.lag.scale_servo_per_s != 0.0 && find(pl.model.cols, Kind::servo))
        return {{kScale, 0, 1.0},
                {kScale, 1, -1.0},
                {kLag, 0, -pl.lag.scale_servo_per_s},
                {kLag, 1, pl.lag.scale_servo_per_s}};
      if (sh.scale) return {{kScale, 0, 1.0}, {kScale, 1, -1.0}};
      break;
    case Kind::servo:
      // Without the feed the column's coefficient is a phase, not a lag (runs.cpp).
      if (sh.lag && pl.samples.speed_known) return {{kLag, 0, 1.0}, {kLag, 1, -1.0}};
      break;
    default:
      break;
  }
  return {};
}

int axis_of(const PlaneFit& pl, int ax) {
  return pl.D.axes[static_cast<std::size_t>(ax)] - 'X';
}

// The standard error given to a plane's mean following lag as an observation of the mean of
// its axes' lags. The mean lag has no standard error of its own; this is far looser than the
// servo mismatch columns (about 1e-6 s), so the lags' differences come from those columns and
// the mean lags set their level; the joint lag is reported without a standard error.
constexpr double kMeanLagSpreadS = 1e-3;

// The joint model's unknowns: shared ones per machine axis, then each plane's own columns. A
// plane's coefficients are theta_p = T_p phi + o_p (o_p: the servo's part of the scale mismatch
// column when the scales are shared and the lags are not, known from the plane's own fit).
struct Layout {
  Sharing sharing;
  std::array<std::array<int, kSharedCount>, 3> shared{};  // [X, Y, Z][param]: index or -1
  std::vector<Eigen::MatrixXd> T;
  std::vector<Eigen::VectorXd> o;
  Eigen::Index size = 0;
};

int shared_index(const Layout& L, const PlaneFit& pl, int ax, int param) {
  return L.shared[static_cast<std::size_t>(axis_of(pl, ax))][static_cast<std::size_t>(param)];
}

Layout lay_out(const std::vector<PlaneFit>& planes, Sharing sh) {
  Layout L;
  L.sharing = sh;
  for (auto& a : L.shared) a.fill(-1);
  for (const auto& pl : planes) {
    for (const Column& c : pl.model.cols) {
      for (const Part& p : shared_parts(pl, c.kind, sh)) {
        int& g = L.shared[static_cast<std::size_t>(axis_of(pl, p.ax))]
                         [static_cast<std::size_t>(p.param)];
        if (g < 0) g = static_cast<int>(L.size++);
      }
    }
  }
  std::vector<Eigen::Index> first_local;
  for (const auto& pl : planes) {
    first_local.push_back(L.size);
    for (const Column& c : pl.model.cols) {
      if (shared_parts(pl, c.kind, sh).empty()) ++L.size;
    }
  }
  for (std::size_t q = 0; q < planes.size(); ++q) {
    const PlaneFit& pl = planes[q];
    const auto p = static_cast<Eigen::Index>(pl.model.cols.size());
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(p, L.size);
    Eigen::VectorXd o = Eigen::VectorXd::Zero(p);
    Eigen::Index local = first_local[q];
    const auto servo = find(pl.model.cols, Kind::servo);
    for (Eigen::Index j = 0; j < p; ++j) {
      const Column& c = pl.model.cols[static_cast<std::size_t>(j)];
      const std::vector<Part> parts = shared_parts(pl, c.kind, sh);
      if (parts.empty()) T(j, local++) = 1.0;
      for (const Part& part : parts) T(j, shared_index(L, pl, part.ax, part.param)) += part.factor;
      const bool lag_in_parts = std::any_of(parts.begin(), parts.end(),
                                            [](const Part& part) { return part.param == kLag; });
      if (c.kind == Kind::scale_mismatch && !parts.empty() && !lag_in_parts && servo)
        o[j] = -pl.lag.scale_servo_per_s * pl.model.sol.x[static_cast<Eigen::Index>(*servo)];
    }
    L.T.push_back(std::move(T));
    L.o.push_back(std::move(o));
  }
  return L;
}

// One more observation of the shared unknowns: a . phi = y with standard error se.
void observe(Normal& J, const Eigen::VectorXd& a, double y, double se) {
  const double w = 1.0 / (std::max(se, 1e-15) * std::max(se, 1e-15));
  J.M += w * a * a.transpose();
  J.v += w * y * a;
  J.yy += w * y * y;
  J.n += 1;
}

// The stacked normal equations: each plane's rows weighted by its own residual variance (a
// noisier plane counts less), and as further observations each plane's mean scale of its two
// axes from its radius change ((s_A + s_B) / 2, with its standard error) and its mean
// following lag ((lag_A + lag_B) / 2).
Normal stack(std::vector<PlaneFit>& planes, const Layout& L, const std::vector<double>& weight) {
  Normal J;
  J.M = Eigen::MatrixXd::Zero(L.size, L.size);
  J.v = Eigen::VectorXd::Zero(L.size);
  for (std::size_t q = 0; q < planes.size(); ++q) {
    PlaneFit& pl = planes[q];
    const Normal N =
        accumulate(pl.samples.S, pl.model.st, pl.model.cols, pl.model.stride, pl.model.memo);
    const Eigen::MatrixXd& T = L.T[q];
    const Eigen::VectorXd& o = L.o[q];
    const Eigen::VectorXd v = N.v - N.M * o;
    J.M += weight[q] * T.transpose() * N.M * T;
    J.v += weight[q] * T.transpose() * v;
    J.yy += weight[q] * (N.yy - 2.0 * o.dot(N.v) + o.dot(N.M * o));
    J.n += N.n;
    const int sa = shared_index(L, pl, 0, kScale), sb = shared_index(L, pl, 1, kScale);
    if (pl.mean_scale.value && sa >= 0 && sb >= 0) {
      Eigen::VectorXd a = Eigen::VectorXd::Zero(L.size);
      a[sa] = a[sb] = 0.5;
      observe(J, a, *pl.mean_scale.value, pl.mean_scale.se);
    }
    const int la = shared_index(L, pl, 0, kLag), lb = shared_index(L, pl, 1, kLag);
    if (pl.lag.lag_s && la >= 0 && lb >= 0) {
      // In the convention of each plane's own axis lag (servo_axes.cpp): the following error
      // over velocity as the trace logs it, without the half sample the continuous loop lags
      // more (servo.cpp adds it to the mean lag).
      Eigen::VectorXd a = Eigen::VectorXd::Zero(L.size);
      a[la] = a[lb] = 0.5;
      observe(J, a, *pl.lag.lag_s - pl.lag.period / 2.0, kMeanLagSpreadS);
    }
  }
  return J;
}

Estimate estimate_at(const Solution& sol, int g, double scale) {
  Estimate e;
  if (g < 0) return e;
  const auto gi = static_cast<Eigen::Index>(g);
  e.value = sol.x[gi] * scale;
  e.standard_error = std::sqrt(std::max(0.0, sol.sigma2 * sol.inv(gi, gi))) * std::abs(scale);
  return e;
}

// Moves v to the joint value b; true when that is a change.
bool move_to(double& v, double b) {
  const bool changed = std::abs(b - v) > 1e-4 * std::abs(b) + 1e-9;
  v = b;
  return changed;
}

// The shared backlash (the play's take-up shape and its offset) and lag mismatch (where the
// reversals fall) into each plane's nonlinear state; true when one moved.
bool take_state(std::vector<PlaneFit>& planes, const Layout& L, const Solution& sol) {
  bool changed = false;
  for (auto& pl : planes) {
    for (int ax = 0; ax < 2; ++ax) {
      const bool reverses = ax == 0 ? pl.samples.reversal_a : pl.samples.reversal_b;
      const int g = shared_index(L, pl, ax, kBacklash);
      if (!reverses || g < 0) continue;
      changed =
          move_to(ax == 0 ? pl.model.st.backlash_a : pl.model.st.backlash_b, sol.x[g]) || changed;
    }
    const int la = shared_index(L, pl, 0, kLag), lb = shared_index(L, pl, 1, kLag);
    if (L.sharing.lag && la >= 0 && lb >= 0 && find(pl.model.cols, Kind::servo))
      changed = move_to(pl.model.st.servo_mismatch_s, sol.x[la] - sol.x[lb]) || changed;
  }
  return changed;
}

// A value and standard error of the joint fit into an axis's joint estimate, judged against
// the planes' own (test_set.cpp); a note when they do not agree with it.
void take_joint(const AxisJoint& a, JointEstimate& j, const Estimate& e, const char* what,
                const char* unit, double factor, std::vector<std::string>& notes) {
  if (auto note = take_joint_value(a, j, e, what, unit, factor)) notes.push_back(std::move(*note));
}

// A joint scale with the planes' largest loop bound (instrument_scale.cpp) in its standard
// error: the same servo in every plane, so no joint fit averages it down.
Estimate with_loop_bound(const std::vector<PlaneFit>& planes, Estimate e) {
  double loop_se = 0.0;
  for (const PlaneFit& pl : planes) loop_se = std::max(loop_se, pl.mean_scale.loop_se);
  if (e.value && loop_se > 0)
    e.standard_error = std::hypot(e.standard_error.value_or(0.0), loop_se * 1e6);
  return e;
}

}  // namespace

SetDiagnosis diagnose_set(std::string source, const std::vector<SetPlaneInput>& inputs) {
  std::vector<PlaneFit> planes;
  std::vector<Diagnosis> own;
  for (const SetPlaneInput& in : inputs) {
    planes.push_back(run_stages({*in.trace, *in.evaluation, in.options}));
    own.push_back(planes.back().D);
  }
  SetDiagnosis s = join_set_diagnoses(std::move(source), std::move(own));
  if (planes.size() < 2) return s;
  // The axes' scales are shared unknowns when a plane gives both the difference of its axes'
  // scales (its scale mismatch column) and their mean (its radius change), the lags when a
  // plane gives both its lag mismatch (its servo column) and its mean lag: any other
  // plane shares an axis with it, so every one is then known; else they are the planes' own.
  Sharing sh;
  sh.scale = std::any_of(planes.begin(), planes.end(), [](const auto& pl) {
    return pl.mean_scale.value && find(pl.model.cols, Kind::scale_mismatch);
  });
  sh.lag = std::any_of(planes.begin(), planes.end(), [](const auto& pl) {
    return find(pl.model.cols, Kind::servo) && pl.lag.lag_s;
  });
  const Layout L = lay_out(planes, sh);
  // Weights 1 / sigma_p^2 from each plane's own fit; equal weights when a plane has no
  // residual left (noise-free data).
  std::vector<double> weight;
  for (const auto& pl : planes) weight.push_back(pl.model.sol.sigma2);
  const bool weighted = std::all_of(weight.begin(), weight.end(), [](double v) { return v > 0; });
  for (double& w : weight) w = weighted ? 1.0 / w : 1.0;
  // The play's take-up depends on the play: a few Gauss-Newton steps, as the plane fit takes.
  Solution sol;
  for (int it = 0; it < 4; ++it) {
    sol = solve(stack(planes, L, weight));
    if (!take_state(planes, L, sol)) break;
  }
  // A joint system the planes do not determine (a shared unknown no plane's data pins down)
  // has no honest solution: the planes' values stay joined as they are, and a note says so.
  if (!sol.x.allFinite() || !sol.inv.diagonal().allFinite() ||
      !(sol.inv.diagonal().minCoeff() > 0)) {
    s.notes.push_back(
        "the joint fit across the planes is singular: the joint values are the inverse-variance "
        "means of the planes' own");
    return s;
  }
  s.joint_fit = true;
  for (AxisJoint& a : s.axes) {
    const auto& g = L.shared[static_cast<std::size_t>(a.axis - 'X')];
    take_joint(a, a.backlash_mm, estimate_at(sol, g[kBacklash], 1.0), "backlash", "um", 1e3,
               s.notes);
    take_joint(a, a.spike_mm, estimate_at(sol, g[kSpike], 1.0), "reversal spike", "um", 1e3,
               s.notes);
    take_joint(a, a.scale_ppm, with_loop_bound(planes, estimate_at(sol, g[kScale], 1e6)), "scale",
               "ppm", 1.0, s.notes);
    if (g[kLag] >= 0) {
      take_joint(a, a.lag_ms, Estimate{sol.x[g[kLag]] * 1e3, std::nullopt}, "following lag", "ms",
                 1.0, s.notes);
    }
  }
  // Each plane's squareness: its own unknown in the joint model, reported where the plane
  // reports it (not confounded with the servo mismatch).
  Eigen::Index first = 0;
  for (const auto& a : L.shared)
    for (int g : a) first += g >= 0 ? 1 : 0;
  Eigen::Index local = first;
  for (const auto& pl : planes) {
    for (const Column& c : pl.model.cols) {
      if (!shared_parts(pl, c.kind, sh).empty()) continue;
      auto& sq = s.squareness_urad[plane_index(pl.D.plane)];
      if (c.kind == Kind::squareness && sq && sq->value)
        sq = estimate_at(sol, static_cast<int>(local), 1e6);
      ++local;
    }
  }
  return s;
}

}  // namespace circtest
