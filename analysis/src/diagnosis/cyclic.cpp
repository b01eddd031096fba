// Cyclic errors (a screw's pitch error): a given pitch, else the peak of a periodogram of the
// residual over axis position, the pitch refined on the profile of the fit.
#include <fmt/format.h>

#include <algorithm>
#include <complex>
#include <numeric>

#include "circtest/core/memory.hpp"
#include "profile.hpp"
#include "stages.hpp"

namespace circtest::diagnosis_detail {

namespace {

// The residual dr - model at every stride-th sample into res[i / stride], on the threads, the
// columns filled in chunks (each kind dispatched once per chunk).
void residual_every(const Samples& S, const State& st, const std::vector<Column>& cols,
                    const Eigen::VectorXd& x, std::size_t stride, std::vector<double>& res) {
  const std::size_t count = (S.size() + stride - 1) / stride;
  if (res.capacity() < count) reserve_huge(res, count);
  res.resize(count);
  const Reversals rev(S, st.servo_mismatch_s);
  for_blocks(S.size(), [&](std::size_t lo, std::size_t hi, std::size_t) {
    std::vector<std::size_t> idx;
    std::vector<Reversal> rvs;
    for (std::size_t i = (lo + stride - 1) / stride * stride; i < hi; i += stride) {
      idx.push_back(i);
      rvs.push_back(rev.at(i));
    }
    const std::size_t m = idx.size();
    std::vector<double> col(m);
    for (std::size_t q = 0; q < m; ++q)
      res[idx[q] / stride] = S.dr[idx[q]] - offset(S, st, cols, idx[q], rvs[q]);
    for (std::size_t j = 0; j < cols.size(); ++j) {
      fill_column(S, st, cols[j], idx.data(), rvs.data(), m, col.data(), 1);
      const double xj = x[static_cast<Eigen::Index>(j)];
      for (std::size_t q = 0; q < m; ++q) res[idx[q] / stride] -= col[q] * xj;
    }
  });
}

struct Peak {
  double pitch_mm = 0.0;
  double ratio = 0.0;  // peak power / median power
};

// Periodogram of the residual projected on one axis, over that axis's position: the residual
// is first reduced to a least-squares axis deviation per position bin.
constexpr std::size_t kMinPeriodogramBins = 16;

// `bins` gets the number of position bins the samples fill (the search needs
// kMinPeriodogramBins).
std::optional<Peak> periodogram(const std::vector<double>& pos, const std::vector<double>& proj,
                                const std::vector<double>& resid, double radius, double min_pitch,
                                std::size_t& bins) {
  bins = 0;
  const auto [mn, mx] = std::minmax_element(pos.begin(), pos.end());
  const double span = *mx - *mn;
  if (!(span > 0)) return std::nullopt;
  const double width = min_pitch / 8.0;
  const auto nbins = static_cast<std::size_t>(std::ceil(span / width)) + 1;
  std::vector<double> sw(nbins, 0.0), swy(nbins, 0.0);
  for (std::size_t i = 0; i < pos.size(); ++i) {
    const auto b = static_cast<std::size_t>((pos[i] - *mn) / width);
    sw[b] += proj[i] * proj[i];
    swy[b] += proj[i] * resid[i];
  }
  std::vector<double> x, y, w;
  std::vector<std::size_t> bin;
  for (std::size_t b = 0; b < nbins; ++b) {
    if (sw[b] <= 0) continue;
    x.push_back(*mn + (static_cast<double>(b) + 0.5) * width);
    y.push_back(swy[b] / sw[b]);
    w.push_back(sw[b]);
    bin.push_back(b);
  }
  bins = x.size();
  if (x.size() < kMinPeriodogramBins) return std::nullopt;
  // Remove the weighted mean so the zero frequency does not leak.
  const double wsum = std::accumulate(w.begin(), w.end(), 0.0);
  double ym = 0.0;
  for (std::size_t k = 0; k < y.size(); ++k) ym += w[k] * y[k];
  ym /= wsum;
  const double fmin = 4.0 / radius;  // pitches up to R/4: longer waves are shape, not pitch
  const double fmax = 1.0 / min_pitch;
  const double df = 1.0 / (4.0 * span);
  if (fmax <= fmin) return std::nullopt;
  std::vector<double> freq;
  for (double f = fmin; f <= fmax; f += df) freq.push_back(f);
  std::vector<double> power(freq.size());
  // The frequencies in chunks side by side. Inside a chunk the bins are the outer loop and the
  // chunk's frequencies the inner one, so their independent rotations run in vector lanes
  // instead of one dependent chain each; every frequency's operations are the same as alone.
  constexpr std::size_t kChunk = 64;
  for_each_task((freq.size() + kChunk - 1) / kChunk, [&](std::size_t chunk) {
    const std::size_t f0 = chunk * kChunk, nf = std::min(freq.size(), f0 + kChunk) - f0;
    // The bins are equally spaced: exp(-2 pi i f x) turns by a fixed step from bin to bin
    // (taken exactly again every 64 bins, so that rounding does not build up).
    std::array<double, kChunk> step_re{}, step_im{}, z_re{}, z_im{}, acc_re{}, acc_im{};
    for (std::size_t t = 0; t < nf; ++t) {
      const double a = -2 * kPi * freq[f0 + t] * width;
      step_re[t] = std::cos(a);
      step_im[t] = std::sin(a);
    }
    std::size_t at = 0, seed = 0;
    for (std::size_t k = 0; k < x.size(); ++k) {
      if (k == 0 || bin[k] >= seed + 64) {
        for (std::size_t t = 0; t < nf; ++t) {
          const double ph = -2 * kPi * freq[f0 + t] * x[k];
          z_re[t] = std::cos(ph);
          z_im[t] = std::sin(ph);
        }
        seed = bin[k];
      } else {
        for (; at < bin[k]; ++at) {
          for (std::size_t t = 0; t < nf; ++t) {
            const double re = z_re[t] * step_re[t] - z_im[t] * step_im[t];
            z_im[t] = z_re[t] * step_im[t] + z_im[t] * step_re[t];
            z_re[t] = re;
          }
        }
      }
      at = bin[k];
      const double wy = w[k] * (y[k] - ym);
      for (std::size_t t = 0; t < nf; ++t) {
        acc_re[t] += wy * z_re[t];
        acc_im[t] += wy * z_im[t];
      }
    }
    for (std::size_t t = 0; t < nf; ++t)
      power[f0 + t] = std::norm(std::complex<double>(acc_re[t], acc_im[t]));
  });
  if (power.size() < 8) return std::nullopt;
  std::vector<double> sorted = power;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                   sorted.end());
  const double median = sorted[sorted.size() / 2];
  const auto it = std::max_element(power.begin(), power.end());
  const auto k = static_cast<std::size_t>(it - power.begin());
  double f = freq[k];
  if (k > 0 && k + 1 < power.size()) {
    const double a = power[k - 1], b = power[k], c = power[k + 1];
    const double den = a - 2 * b + c;
    if (den < 0) f += 0.5 * (a - c) / den * df;
  }
  Peak peak;
  peak.pitch_mm = 1.0 / f;
  peak.ratio = median > 0 ? *it / median : std::numeric_limits<double>::infinity();
  return peak;
}

// The cyclic terms of axis ax (0: A, 1: B).
Kind cyclic_sin(int ax) {
  return ax == 0 ? Kind::cyclic_a_sin : Kind::cyclic_b_sin;
}
Kind cyclic_cos(int ax) {
  return ax == 0 ? Kind::cyclic_a_cos : Kind::cyclic_b_cos;
}

}  // namespace

void take_cyclic_fit(const Model& m, int ax, CyclicEstimate& ce) {
  const Solution& sol = m.sol;
  const auto js = static_cast<Eigen::Index>(*find(m.cols, cyclic_sin(ax)));
  const auto jc = static_cast<Eigen::Index>(*find(m.cols, cyclic_cos(ax)));
  const double a = sol.x[js], b = sol.x[jc];
  ce.amplitude_mm = std::hypot(a, b);
  ce.phase_rad = std::atan2(b, a);
  // Amplitude standard error: the larger of the two components' (a conservative bound).
  ce.amplitude_se_mm = std::sqrt(sol.sigma2 * std::max(sol.inv(js, js), sol.inv(jc, jc)));
}

// Cyclic errors: a given pitch, else a periodogram of the residual over axis position.
CyclicErrors find_cyclic(const Inputs& in, const TraceDescription& td, const SampleSet& ss,
                         Model& m, Diagnosis& D) {
  const DiagnosisOptions& options = in.options;
  const Samples& S = ss.S;
  CyclicErrors out;
  std::vector<Column>& cols = m.cols;
  State& st = m.st;
  const Solution& sol = m.sol;
  const char la = td.la, lb = td.lb;
  const std::string &A = td.A, &B = td.B;
  const double R = ss.R;
  auto fit = [&] { diagnosis_detail::fit(S, m); };
  std::vector<double> res;
  // The columns and state `res` was taken at; none before the first residual (an empty
  // column set at the default state is a state like any other, not "already taken").
  std::optional<std::pair<std::vector<Column>, State>> res_at;
  const std::size_t cstride = std::max<std::size_t>(1, (S.size() + 199999) / 200000);
  for (int ax = 0; ax < 2; ++ax) {
    const char letter = ax == 0 ? la : lb;
    std::optional<CyclicEstimate> found;
    double pitch = 0.0;
    auto it = options.pitch_mm.find(letter);
    CyclicEstimate ce;
    if (it != options.pitch_mm.end()) {
      pitch = it->second;
      ce.pitch_source = "option";
    } else {
      // Every cstride-th sample, entry i / cstride, on the threads. The residual is the
      // same for both axes unless the first one added a cyclic term.
      const std::size_t count = (S.size() + cstride - 1) / cstride;
      std::vector<double> pos, proj;
      for (auto* v : {&pos, &proj}) {
        reserve_huge(*v, count);
        v->resize(count);
      }
      if (!res_at || !(res_at->first == cols && res_at->second == st)) {
        residual_every(S, st, cols, sol.x, cstride, res);
        res_at.emplace(cols, st);
      }
      for_blocks(S.size(), [&](std::size_t lo, std::size_t hi, std::size_t) {
        for (std::size_t i = (lo + cstride - 1) / cstride * cstride; i < hi; i += cstride) {
          pos[i / cstride] = S.pos(ax, i);
          proj[i / cstride] = ax == 0 ? S.c[i] : S.s[i];
        }
      });
      const double min_pitch = std::max(0.5, R / 400.0);
      std::size_t bins = 0;
      const auto peak = periodogram(pos, proj, res, R, min_pitch, bins);
      if (bins < kMinPeriodogramBins) {
        D.notes.push_back(fmt::format(
            "cyclic error of {} not measurable ({} samples fill {} position bins of {:.3g} "
            "mm, needs {}): give its pitch with --pitch to fit it",
            ax == 0 ? A : B, pos.size(), bins, min_pitch / 8.0, kMinPeriodogramBins));
      }
      if (peak && peak->ratio >= options.cyclic_detection_factor) {
        pitch = peak->pitch_mm;
        ce.pitch_source = "periodogram";
        ce.peak_to_median_power = peak->ratio;
      } else if (peak) {
        ce.peak_to_median_power = peak->ratio;
      }
    }
    if (pitch <= 0) continue;
    const Kind ks = cyclic_sin(ax);
    const Kind kc = cyclic_cos(ax);
    double& st_pitch = ax == 0 ? st.pitch_a : st.pitch_b;
    if (ce.pitch_source == "periodogram") {
      // Refine the pitch on the profile residual.
      const double f0 = 1.0 / pitch;
      double span = 0.0;
      { span = S.pos_span(ax); }
      const double df = 1.0 / (4.0 * span);
      const Profile prof = make_profile(S, st, cols, sol, cstride);
      auto rss_at = [&](double f) {
        State s2 = st;
        (ax == 0 ? s2.pitch_a : s2.pitch_b) = 1.0 / f;
        return profile_rss(S, s2, prof, {{ks}, {kc}});
      };
      pitch = 1.0 / golden(rss_at, f0 - df, f0 + df, 16);
    }
    st_pitch = pitch;
    cols.push_back({ks});
    cols.push_back({kc});
    fit();
    ce.pitch_mm = pitch;
    take_cyclic_fit(m, ax, ce);
    if (ce.pitch_source == "periodogram" && (ce.amplitude_mm < options.min_cyclic_amplitude_mm ||
                                             ce.amplitude_mm < 5.0 * ce.amplitude_se_mm)) {
      // A peak of a residual that is itself negligible: not a cyclic error.
      cols.resize(cols.size() - 2);
      st_pitch = 0.0;
      fit();
      continue;
    }
    found = ce;
    out[static_cast<std::size_t>(ax)] = found;
  }
  return out;
}

// With the spikes in the model, a pitch found by the periodogram is refined once more, and
// the spikes are searched again with that pitch.
bool refine_cyclic(const Inputs& in, const SampleSet& ss, Model& m, CyclicErrors& cyclic) {
  const DiagnosisOptions& options = in.options;
  const Samples& S = ss.S;
  std::vector<Column>& cols = m.cols;
  State& st = m.st;
  const Solution& sol = m.sol;
  auto fit = [&] { diagnosis_detail::fit(S, m); };
  bool refined = false;
  for (int ax = 0; ax < 2; ++ax) {
    auto& cy = cyclic[static_cast<std::size_t>(ax)];
    if (!cy || cy->pitch_source != "periodogram") continue;
    const Kind ks = cyclic_sin(ax);
    const Kind kc = cyclic_cos(ax);
    cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*find(cols, ks)));
    cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*find(cols, kc)));
    fit();
    const double df = 1.0 / (16.0 * S.pos_span(ax));
    const std::size_t cstride = std::max<std::size_t>(1, (S.size() + 199999) / 200000);
    const Profile prof = make_profile(S, st, cols, sol, cstride);
    auto rss_at = [&](double f) {
      State s2 = st;
      (ax == 0 ? s2.pitch_a : s2.pitch_b) = 1.0 / f;
      return profile_rss(S, s2, prof, {{ks}, {kc}});
    };
    const double pitch = 1.0 / golden(rss_at, 1.0 / cy->pitch_mm - df, 1.0 / cy->pitch_mm + df, 14);
    (ax == 0 ? st.pitch_a : st.pitch_b) = pitch;
    cols.push_back({ks});
    cols.push_back({kc});
    fit();
    cy->pitch_mm = pitch;
    take_cyclic_fit(m, ax, *cy);
    refined = true;
    // The peak may have been the spikes' residual before they were fitted: the same test as
    // when it was found, now with the spikes in the model.
    if (cy->amplitude_mm < options.min_cyclic_amplitude_mm ||
        cy->amplitude_mm < 5.0 * cy->amplitude_se_mm) {
      cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*find(cols, ks)));
      cols.erase(cols.begin() + static_cast<std::ptrdiff_t>(*find(cols, kc)));
      (ax == 0 ? st.pitch_a : st.pitch_b) = 0.0;
      cy.reset();
      fit();
    }
  }
  return refined;
}

}  // namespace circtest::diagnosis_detail
