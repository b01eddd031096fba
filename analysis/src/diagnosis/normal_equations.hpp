#pragma once
// The normal equations of the diagnosis model: sums over the samples (with the steady sums of
// the rows away from the reversals, so that a Gauss-Newton step works out only the rows near
// them), their solution and the identifiability measure.
#include <Eigen/Dense>
#include <optional>
#include <vector>

#include "model.hpp"

namespace circtest::diagnosis_detail {

struct Normal {
  Eigen::MatrixXd M;  // J^T J
  Eigen::VectorXd v;  // J^T y
  double yy = 0.0;
  std::size_t n = 0;
};

// Sums of a set of rows: J^T J (upper triangle), J^T Y and Y^T Y for the right-hand sides
// in Y's columns.
struct Sums {
  Eigen::MatrixXd M, V, YY;
  std::size_t n = 0;
  Sums(Eigen::Index p, Eigen::Index k)
      : M(Eigen::MatrixXd::Zero(p, p)),
        V(Eigen::MatrixXd::Zero(p, k)),
        YY(Eigen::MatrixXd::Zero(k, k)) {}
  Sums& operator+=(const Sums& o) {
    M += o.M;
    V += o.V;
    YY += o.YY;
    n += o.n;
    return *this;
  }
};

// The sums of the rows away from every reversal, for one set of columns. There a row's columns
// do not depend on the play, and on the lag mismatch (within the window) only through factors
// common to all such rows: the backlash columns are +-1/2 cos or sin, a spike column scales by
// one factor per axis (steady_normal), and the servo offset is the lag mismatch squared times
// a fixed function. A Gauss-Newton step then works out only the rows
// near a reversal (a few percent) and adds these sums. The windows are angles before and
// after the reversals as they were when the sums were taken; a state that moves a reversal or
// a take-up of the play out of them makes the sums be taken again.
struct SteadySums {
  std::vector<Column> cols;
  std::size_t stride = 0;
  State ref;                       // the state they were taken at
  std::vector<double> before_rad;  // per run: window before a reversal
  std::vector<double> after_rad;   // per run: window after a reversal
  std::vector<std::size_t> near;   // the stride rows inside a window, in order
  std::optional<Sums> sums;        // of the others, Y = (dr, servo_offset_per_s2)
};

// The normal equations already built: the last ones (the first step of a fit often asks again
// for those the identifiability check just built), and the steady sums of the last columns.
struct NormalMemo {
  std::vector<Column> cols;
  State st;
  std::size_t stride = 0;
  Normal N;
  std::optional<SteadySums> steady;
};

struct Solution {
  Eigen::VectorXd x;
  Eigen::MatrixXd inv;  // (J^T J)^-1
  double rss = 0.0;
  double sigma2 = 0.0;
};

// The normal equations of the model `cols` at state st over every stride-th sample (less those
// at a reversal), taken from the memo when it holds them and from its steady sums when valid.
Normal accumulate(const Samples& S, const State& st, const std::vector<Column>& cols,
                  std::size_t stride, NormalMemo& memo);
// The least-squares solution, its (J^T J)^-1, residual sum of squares and variance.
Solution solve(const Normal& N);
// The coefficients of column j regressed on the columns in `set` (normalised to unit diagonal).
Eigen::VectorXd regression(const Eigen::MatrixXd& C, const std::vector<Eigen::Index>& set,
                           Eigen::Index j);
// 1 - R^2 of column j regressed on the columns in `set` (all normalised to unit diagonal).
double unexplained(const Eigen::MatrixXd& C, const std::vector<Eigen::Index>& set, Eigen::Index j);

}  // namespace circtest::diagnosis_detail
