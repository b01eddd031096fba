// The reversal spike friction makes on a servo, measured by the diagnosis: a circle whose
// table positions come from the commanded ones through a P position loop driving circdrive's
// velocity-mode drive model (hal-component/circdrive: motor lag, integral action, Coulomb friction
// and stiction), the model configs/sim-servo runs in LinuxCNC. The table sticks at each
// reversal, the deviation grows until the drive breaks free and then falls: a spike that rises
// after the reversal, not the decaying step the fit's term describes. The truth is the same
// loop without friction subtracted from the one with it (the friction's own deviation),
// averaged over the reversals: its peak is the height, the time from the peak to 1/e of it
// the decay.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "circdrive_kernel.hpp"
#include "circtest/analysis/diagnosis.hpp"
#include "machine_sim.hpp"

using namespace circtest;

namespace {

struct Friction {
  double p_per_s = 30.0;                  // position-loop gain
  double coulomb = 0.8, breakaway = 1.2;  // mm/s, circdrive's units
  double tau_s = 0.004, ti_s = 0.02;
};

// The positions of a P loop (the pid of sim-servo.hal: the previous period's command against
// the feedback) driving circdrive from the commanded column.
std::vector<double> through_loop(const std::vector<double>& cmd, double period_s, const Friction& f,
                                 bool with_friction) {
  drive::Drive d;
  drive::Params p;
  p.enable = true;
  p.tau_s = f.tau_s;
  p.ti_s = f.ti_s;
  p.coulomb = with_friction ? f.coulomb : 0.0;
  p.breakaway = with_friction ? f.breakaway : 0.0;
  d.reset(cmd.front());
  std::vector<double> out(cmd.size());
  double previous = cmd.front();
  for (std::size_t i = 0; i < cmd.size(); ++i) {
    const double v = std::clamp(f.p_per_s * (previous - d.position()), -150.0, 150.0);
    previous = cmd[i];
    out[i] = d.step(v, period_s, p);
  }
  return out;
}

struct Truth {
  double height_mm = 0.0, decay_ms = 0.0, peak_ms = 0.0;
};

// The friction's deviation after each reversal of the frictionless table inside the measured
// arcs, outwards positive, averaged over the reversals; its peak and fall to 1/e.
Truth truth_of(const std::vector<double>& with, const std::vector<double>& without,
               const std::vector<double>& marker, double period_s) {
  const auto window = static_cast<std::size_t>(std::lround(1.0 / period_s));
  std::vector<double> sum(window, 0.0);
  int count = 0;
  for (std::size_t i = 2; i + window < with.size(); ++i) {
    const double v0 = without[i - 1] - without[i - 2], v1 = without[i] - without[i - 1];
    if (!(v0 * v1 < 0) || marker[i] != 1.0) continue;
    const double old_dir = v0 > 0 ? 1.0 : -1.0;
    for (std::size_t k = 0; k < window; ++k) sum[k] += old_dir * (with[i + k] - without[i + k]);
    ++count;
  }
  Truth t;
  if (count == 0) return t;
  const auto peak = std::max_element(sum.begin(), sum.end()) - sum.begin();
  t.height_mm = sum[static_cast<std::size_t>(peak)] / count;
  t.peak_ms = static_cast<double>(peak) * period_s * 1e3;
  for (auto k = static_cast<std::size_t>(peak); k < window; ++k) {
    if (sum[k] / count < t.height_mm / std::exp(1.0)) {
      t.decay_ms = static_cast<double>(k - static_cast<std::size_t>(peak)) * period_s * 1e3;
      break;
    }
  }
  return t;
}

struct Case {
  const char* name;   // for the output
  const char* label;  // the test's name
  Friction x, y;
  double radius_mm, feed;
};

class FrictionSpike : public ::testing::TestWithParam<Case> {};

}  // namespace

TEST_P(FrictionSpike, HeightAndDecayAreThoseOfTheStick) {
  const Case& c = GetParam();
  sim::CircleProgram prog;
  prog.radius_mm = c.radius_mm;
  prog.feed_mm_per_min = c.feed;
  Trace trace = sim::simulate(sim::MachineModel{}, prog);
  const double period = prog.period_s;
  const auto& marker = *trace.column("marker");
  std::array<Truth, 2> truth;
  for (int ax = 0; ax < 2; ++ax) {
    const std::string axis = ax == 0 ? "x" : "y";
    const Friction& f = ax == 0 ? c.x : c.y;
    const auto& cmd = *trace.column(axis + "_cmd");
    const std::vector<double> with = through_loop(cmd, period, f, true);
    truth[static_cast<std::size_t>(ax)] =
        truth_of(with, through_loop(cmd, period, f, false), marker, period);
    trace.values[*trace.column_index(axis)] = with;
  }
  const Diagnosis d = diagnose(trace);
  // The spike enters the model as its measured profile: what the model leaves of the circle
  // is a small part of its G (as a decaying step, a third or more).
  ASSERT_TRUE(d.measured_g_mm);
  EXPECT_LE(d.residual_g_mm, 0.15 * *d.measured_g_mm)
      << "residual G " << d.residual_g_mm * 1e3 << " um of " << *d.measured_g_mm * 1e3 << " um";
  for (int ax = 0; ax < 2; ++ax) {
    const auto axs = static_cast<std::size_t>(ax);
    const Truth& t = truth[axs];
    SCOPED_TRACE(ax == 0 ? "X" : "Y");
    ASSERT_GT(t.height_mm, 2e-3) << "the friction makes a spike of micrometres";
    ASSERT_TRUE(d.spike_mm[axs].value && d.spike_ms[axs].value);
    ASSERT_TRUE(d.spike_peak_ms[axs].value);
    std::printf(
        "%s %c: spike %.3f um (truth %.3f), decay %.1f ms (truth %.1f), peak at %.1f ms (truth "
        "%.1f), backlash %.3f um\n",
        c.name, d.axes[axs], *d.spike_mm[axs].value * 1e3, t.height_mm * 1e3,
        *d.spike_ms[axs].value, t.decay_ms, *d.spike_peak_ms[axs].value, t.peak_ms,
        d.backlash_mm[axs].value.value_or(NAN) * 1e3);
    // The time from the reversal to the peak (circfric's rise is set from it): within 10 % or
    // 3 servo periods (the profile's bins are a period wide and its top is flat).
    EXPECT_NEAR(*d.spike_peak_ms[axs].value, t.peak_ms, std::max(0.1 * t.peak_ms, 3.0));
    // 5 % (the fit of the other terms moves the baseline a little), and the decay within
    // 10 % or 2 servo periods (the 1/e crossing lies between two samples).
    EXPECT_NEAR(*d.spike_mm[axs].value, t.height_mm, 0.05 * t.height_mm);
    EXPECT_NEAR(*d.spike_ms[axs].value, t.decay_ms, std::max(0.1 * t.decay_ms, 2.0));
    ASSERT_TRUE(d.spike_mm[axs].standard_error);
    EXPECT_LT(*d.spike_mm[axs].standard_error, 0.1 * t.height_mm);
  }
  // The report says the spike was measured on its profile, with each direction of reversal
  // (the friction is symmetric here: the same height both ways within 5 %).
  for (const char axis : {'X', 'Y'}) {
    const std::string head = std::string("reversal spike ") + axis + " rises after the reversal";
    const auto note = std::find_if(d.notes.begin(), d.notes.end(),
                                   [&](const std::string& n) { return n.starts_with(head); });
    ASSERT_NE(note, d.notes.end()) << head;
    const std::string to_plus = std::string(" um at the reversals to +") + axis;
    const std::string to_minus = std::string(" um at the reversals to -") + axis;
    const auto at_plus = note->find(to_plus), at_minus = note->find(to_minus);
    ASSERT_NE(at_plus, std::string::npos) << *note;
    ASSERT_NE(at_minus, std::string::npos) << *note;
    const double plus = std::stod(note->substr(note->rfind(' ', at_plus - 1) + 1));
    const double minus = std::stod(note->substr(note->rfind(' ', at_minus - 1) + 1));
    EXPECT_NEAR(plus, minus, 0.05 * std::max(plus, minus)) << *note;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Servo, FrictionSpike,
    ::testing::Values(
        // sim-servo's X and Y drives (configs/sim-servo/sim-servo.ini [SIM], P 30 / 31).
        Case{"sim-servo D150 F1000",
             "SimServo",
             {30.0, 0.8, 1.2, 0.004, 0.02},
             {31.0, 0.5, 0.8, 0.006, 0.02},
             75.0,
             1000.0},
        // Other circles, feeds, gains and friction. (At D50 F2000 the stick lasts no longer than
        // the lag, the fit takes part of it as backlash, and the height is off by some 20 %:
        // docs/circfric.md, LIMITS.)
        Case{"D100 F1000",
             "D100",
             {30.0, 0.8, 1.2, 0.004, 0.02},
             {45.0, 0.3, 0.6, 0.005, 0.03},
             50.0,
             1000.0},
        Case{"D150 F1500",
             "D150F1500",
             {30.0, 0.8, 1.2, 0.004, 0.02},
             {45.0, 0.3, 0.6, 0.005, 0.03},
             75.0,
             1500.0},
        Case{"D150 F1000 other",
             "Other",
             {40.0, 0.4, 1.0, 0.004, 0.02},
             {45.0, 0.3, 0.6, 0.005, 0.03},
             75.0,
             1000.0}),
    [](const ::testing::TestParamInfo<Case>& p) { return std::string(p.param.label); });

namespace {

// The demo's machine before compensation (scripts/demo.sh on configs/sim-servo): each axis a P
// loop (30 and 31 1/s, FF1 0: unequal lags) driving circdrive with friction, then the
// geometry of configs/sim-servo/geometry.hal: the screw follows the motor through a play
// (limit1 between motor - b/2 and motor + b/2), scale, squareness (x += alpha y), and a cyclic
// error on Y tied to its motor position.
struct MainJob {
  double backlash_x_mm = 0.010;
  double scale_x = 50e-6;
  double squareness_rad = 100e-6;
  double cyclic_y_mm = 0.002, pitch_y_mm = 5.0;
  Friction x{30.0, 0.8, 1.2, 0.004, 0.02}, y{31.0, 0.5, 0.8, 0.006, 0.02};
};

// The screw through a play of b around the motor.
std::vector<double> through_play(const std::vector<double>& motor, double b) {
  std::vector<double> screw(motor.size());
  double s = motor.front();
  for (std::size_t i = 0; i < motor.size(); ++i) {
    s = std::clamp(s, motor[i] - b / 2, motor[i] + b / 2);
    screw[i] = s;
  }
  return screw;
}

// The demo's circle (D100, F1000, CCW and CW) on that machine; the motor positions as the
// feedback columns, as circlog logs them.
Trace main_job_trace(const MainJob& m) {
  sim::CircleProgram prog;
  prog.radius_mm = 50.0;
  prog.feed_mm_per_min = 1000.0;
  prog.lead_deg = 10.0;
  Trace trace = sim::simulate(sim::MachineModel{}, prog);
  const double period = prog.period_s;
  const std::vector<double> mx = through_loop(*trace.column("x_cmd"), period, m.x, true);
  const std::vector<double> my = through_loop(*trace.column("y_cmd"), period, m.y, true);
  const std::vector<double> sx = through_play(mx, m.backlash_x_mm);
  std::vector<double> tx(sx.size()), ty(sx.size());
  for (std::size_t i = 0; i < sx.size(); ++i) {
    const double x = sx[i] * (1.0 + m.scale_x), y = my[i];
    tx[i] = x + m.squareness_rad * y;
    ty[i] = y + m.cyclic_y_mm * std::sin(2.0 * std::numbers::pi * my[i] / m.pitch_y_mm);
  }
  trace.values[*trace.column_index("x")] = tx;
  trace.values[*trace.column_index("y")] = ty;
  trace.columns.push_back("x_fb");
  trace.values.push_back(mx);
  trace.columns.push_back("y_fb");
  trace.values.push_back(my);
  return trace;
}

}  // namespace

// The main job before compensation: the model explains the circle (the residual's G is at
// most 15 % of the measured G) and recovers every injected source. The spikes rise after the
// reversal (friction's stick): taken as a decaying step, 42 % of G stayed unexplained on this
// circle, and the decaying step took some of the backlash and the lag mismatch with it.
TEST(MainJob, TheModelExplainsTheCircleAndRecoversTheInjectedSources) {
  const MainJob m;
  const Trace trace = main_job_trace(m);
  const Evaluation ev = evaluate(trace, {});
  double g_mm = 0.0;
  for (const RunResult& r : ev.runs) g_mm = std::max(g_mm, r.g_lsc_mm);
  const Diagnosis d = diagnose(trace, ev, {});
  std::printf("G %.2f um, residual G %.2f um (%.1f %%), RMS %.3f um\n", g_mm * 1e3,
              d.residual_g_mm * 1e3, 100.0 * d.residual_g_mm / g_mm, d.residual_rms_mm * 1e3);
  ASSERT_GT(g_mm, 25e-3) << "the circle of the main job: G some 35 um";
  EXPECT_LE(d.residual_g_mm, 0.15 * g_mm);
  ASSERT_TRUE(d.measured_g_mm);
  EXPECT_DOUBLE_EQ(*d.measured_g_mm, g_mm);
  // The injected sources, within 5 % or 0.3 um, 3 ppm, 2 urad, 0.02 ms.
  ASSERT_TRUE(d.backlash_mm[0].value && d.backlash_mm[1].value);
  EXPECT_NEAR(*d.backlash_mm[0].value, m.backlash_x_mm, 0.05 * m.backlash_x_mm);
  EXPECT_NEAR(*d.backlash_mm[1].value, 0.0, 0.3e-3);
  ASSERT_TRUE(d.scale_ppm[0].value && d.scale_ppm[1].value);
  EXPECT_NEAR(*d.scale_ppm[0].value, m.scale_x * 1e6, 3.0);
  EXPECT_NEAR(*d.scale_ppm[1].value, 0.0, 3.0);
  ASSERT_TRUE(d.squareness_urad.value);
  EXPECT_NEAR(*d.squareness_urad.value, m.squareness_rad * 1e6, 2.0);
  ASSERT_TRUE(d.servo_mismatch_ms.value);
  EXPECT_NEAR(*d.servo_mismatch_ms.value, (1.0 / m.x.p_per_s - 1.0 / m.y.p_per_s) * 1e3, 0.02);
  ASSERT_TRUE(d.cyclic[1]);
  EXPECT_NEAR(d.cyclic[1]->amplitude_mm, m.cyclic_y_mm, 0.3e-3);
  EXPECT_NEAR(d.cyclic[1]->pitch_mm, m.pitch_y_mm, 0.01 * m.pitch_y_mm);
  EXPECT_FALSE(d.cyclic[0]);
  // The spikes against the friction's own deviation at the table: the loop with friction
  // less the loop without, each through the axis' play (on X the play takes up part of the
  // motor's stick before the table sees it).
  const auto& marker = *trace.column("marker");
  for (int ax = 0; ax < 2; ++ax) {
    const auto axs = static_cast<std::size_t>(ax);
    const Friction& f = ax == 0 ? m.x : m.y;
    const double b = ax == 0 ? m.backlash_x_mm : 0.0;
    const auto& cmd = *trace.column(ax == 0 ? "x_cmd" : "y_cmd");
    // The reversals from the motor without friction (through the play the table stands still
    // a while, with no sign change to find).
    const std::vector<double> motor = through_loop(cmd, 0.001, f, false);
    const std::vector<double> with = through_play(through_loop(cmd, 0.001, f, true), b);
    const std::vector<double> without = through_play(motor, b);
    std::vector<double> shifted(motor.size());
    for (std::size_t i = 0; i < motor.size(); ++i) shifted[i] = motor[i] + with[i] - without[i];
    const Truth t = truth_of(shifted, motor, marker, 0.001);
    ASSERT_GT(t.height_mm, 2e-3) << ax;
    ASSERT_TRUE(d.spike_mm[axs].value && d.spike_peak_ms[axs].value) << ax;
    std::printf("%c: spike %.3f um (truth %.3f), peak at %.1f ms (%.1f)\n", d.axes[axs],
                *d.spike_mm[axs].value * 1e3, t.height_mm * 1e3, *d.spike_peak_ms[axs].value,
                t.peak_ms);
    EXPECT_NEAR(*d.spike_mm[axs].value, t.height_mm, 0.05 * t.height_mm) << ax;
    EXPECT_NEAR(*d.spike_peak_ms[axs].value, t.peak_ms, std::max(0.1 * t.peak_ms, 3.0)) << ax;
  }
}
