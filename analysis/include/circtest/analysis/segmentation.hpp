#pragma once
// Splitting a trace into the measured runs of a circular test.
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/core/plane.hpp"
#include "circtest/core/trace.hpp"

namespace circtest {

// The two position columns of the plane under test, as indices into trace.values (found by
// plane_columns(), which refuses a trace without them).
struct PlaneColumns {
  std::size_t a = 0;
  std::size_t b = 0;
};

// Finds the columns for a plane (its two lowercase axis letters, or explicit names).
// Throws ParseError at the header line when a column is missing.
PlaneColumns plane_columns(const Trace& trace, Plane plane, const std::string& a_name = {},
                           const std::string& b_name = {});

enum class SegmentationMethod { marker, segment, automatic };

struct Run {
  std::size_t begin = 0;  // first row (inclusive)
  std::size_t end = 0;    // last row (exclusive)
  Direction direction = Direction::CCW;
  double sweep_deg = 0.0;  // swept angle, positive
  double start_deg = 0.0;  // angle of the first point about the run's centre estimate
  long segment_id = 0;     // the `segment` column's value, 0 when absent
  std::size_t size() const { return end - begin; }
};

// The back-travel that makes a reversal inside a marked span: far above the jitter of a
// dwell (a few thousandths of a degree), far below any arc the standard evaluates.
inline constexpr double kReversalDeg = 5.0;

struct SegmentationOptions {
  // Centre estimate for the angles (nominal centre); estimated from the data when absent.
  std::optional<PlanePoint> centre;
  std::optional<double> radius_mm;
  double min_sweep_deg = 90.0;  // shorter runs are refused (DataError naming their lines)
  std::size_t min_points = 8;
  // Marked spans are worked out side by side on up to this many threads (0: one per core).
  unsigned threads = 0;
};

struct Segmentation {
  SegmentationMethod method = SegmentationMethod::automatic;
  std::vector<Run> runs;
  std::vector<std::string> notes;  // for the report: e.g. a marked span split at a reversal
};

// Runs are the stretches where `marker` is non-zero (split where `segment` changes, and
// where the rotation reverses by more than kReversalDeg: one marked span holding a CCW and a
// CW run becomes two runs, with a note); else
// the stretches of one non-zero `segment` value trimmed to the arc at constant radius;
// else found automatically: moving samples at the circle's radius, split where the
// direction of rotation changes, with dwells, feed-in moves and lead arcs off the circle
// dropped, and any overtravel beyond 360 deg trimmed evenly from both ends.
Segmentation segment_trace(const Trace& trace, PlaneColumns columns,
                           const SegmentationOptions& options = {});

const char* segmentation_method_name(SegmentationMethod method) noexcept;
std::optional<SegmentationMethod> parse_segmentation_method(std::string_view name);

}  // namespace circtest
