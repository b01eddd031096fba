#pragma once
// Profiling added columns against a base fit without refitting it: the pitch refinement and
// the spike decay search evaluate hundreds of trial columns on a subsample.
#include <Eigen/Dense>
#include <array>
#include <memory>
#include <vector>

#include "normal_equations.hpp"

namespace circtest::diagnosis_detail {

// The base fit's design rows and residual on a subsample, for profiling added columns. Its
// arrays (about 17 MB for 60,000 rows) live in one block asked for huge pages: allocated one
// by one they cost thousands of page faults, more than the arithmetic on them.
using MatMap = Eigen::Map<Eigen::MatrixXd, Eigen::AlignedMax>;
using VecMap = Eigen::Map<Eigen::VectorXd, Eigen::AlignedMax>;

struct Profile {
  Profile() = default;
  Profile(const Profile&) = delete;
  Profile& operator=(const Profile&) = delete;
  Profile(Profile&&) = default;  // the block moves with its buffer: the maps stay valid

  std::unique_ptr<double[]> store;  // the block the maps below point into
  std::vector<std::size_t> index;   // sample indices
  MatMap J{nullptr, 0, 0};          // rows of the base columns
  VecMap e{nullptr, 0};             // base residual
  Eigen::MatrixXd inv;              // (J^T J)^-1 of the base fit (full-data scaling)
  double rss = 0.0;
  // The spike terms' parts that do not depend on the decay, per axis and profile row: the
  // signed projection (-direction * cos or sin) and the time since the reversal (negative when
  // the feed is unknown). The decay search evaluates the spike columns hundreds of times.
  std::array<VecMap, 2> spike_sign{VecMap{nullptr, 0}, VecMap{nullptr, 0}};
  std::array<VecMap, 2> spike_dt_s{VecMap{nullptr, 0}, VecMap{nullptr, 0}};
  // The same per axis over only the rows past a reversal (time known), ordered by the time
  // since it, with their base design rows and residual: a spike column at decay tau is zero
  // past ~40 tau, so an evaluation reads only the leading rows.
  struct SpikeRows {
    std::vector<Eigen::Index> row;   // profile row of each ordered row
    std::vector<Eigen::Index> rank;  // per profile row: its place in this order, or -1
    VecMap sign{nullptr, 0}, dt_s{nullptr, 0}, e{nullptr, 0};
    MatMap J{nullptr, 0, 0};
  };
  std::array<SpikeRows, 2> spike_rows;
};

// The profile of the base fit (columns cols at st, solution base) on every stride-th sample.
Profile make_profile(const Samples& S, const State& st, const std::vector<Column>& cols,
                     const Solution& base, std::size_t stride);
// profile_rss for spike columns only (the decay search), on the ordered rows: each column is
// evaluated on the rows with dt < 40 tau (exp(-40) = 4e-18 of the height; the rest add nothing
// the sums could hold), so a short decay costs a small part of a full evaluation.
double spike_profile_rss(const Profile& P, const State& st, const std::vector<Column>& extra);
// Residual sum of squares when the columns `extra` join the base fit:
// RSS_base - g^T H^-1 g with g = S^T e0 and H = S^T S - S^T J (J^T J)^-1 J^T S.
double profile_rss(const Samples& S, const State& st, const Profile& P,
                   const std::vector<Column>& extra);

}  // namespace circtest::diagnosis_detail
