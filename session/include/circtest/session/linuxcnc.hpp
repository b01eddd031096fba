#pragma once
// The running LinuxCNC as a session sees it, through the LinuxCNC link (the helper program
// circtest-linuxcnc, LinuxCNC's `linuxcnc` Python module: NML as linuxcncrsh and halui use
// it) and halcmd.
#include <array>
#include <string>
#include <vector>

namespace circtest::session {

struct MachineState {
  std::string task_state;  // estop, estop-reset, off, on
  bool estop = true;
  std::vector<bool> homed;   // per joint
  std::string interp_state;  // idle, reading, paused, waiting
  double feed_override = 1.0;
  std::array<double, 3> work_origin_machine_mm{};  // G5x + G92 (+ tool length on Z)
  std::string ini_filename;                        // the INI LinuxCNC runs
};

// Asks the running LinuxCNC; throws HalError (exit 7) when none runs.
MachineState machine_state();

// Throws HalError with one line for the first thing that keeps the test from starting: another
// configuration running, E-stop, machine off, joints not homed, a program running, the feed
// override not at 100 %.
void require_ready(const MachineState& state, const std::string& ini_path);

// Throws HalError unless circlog is loaded with CHANNELS channels and its function is in a
// thread (circtest install written and LinuxCNC restarted since).
void require_circlog(std::size_t channels);

// An aborted program leaves circlog's marker output on, and the recorder would take what
// follows for a run: switches the outputs off by MDI (M65, M68) when circlog.0.enable is on.
// True when it did; throws HalError when LinuxCNC did not run them.
bool clear_markers(int marker_output, int segment_output);

}  // namespace circtest::session
