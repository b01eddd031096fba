#include "recorder.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <memory>
#include <numbers>
#include <set>
#include <sstream>

#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/progress.hpp"
#include "circtest/core/sha256.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace.hpp"
#include "circtest/core/trace_keys.hpp"

namespace circtest::circlog_record {

namespace {

// How long the recorder waits before it gives up or moves on, in seconds of monotonic time.
// A loaded circlog whose function is not added never counts a period: refuse after this.
constexpr double kServoStartTimeout_s = 5.0;
// A running servo thread counts a period every millisecond or so: this long without one means
// it stopped (LinuxCNC shut down), and the trace ends with that reason.
constexpr double kServoStallTimeout_s = 2.0;
// After release(), at most this long for the two periods that let the writer finish a record.
constexpr double kReleaseSettle_s = 0.5;

// The trailer's account of the runs the program announced (--program).
constexpr const char* kRunsAnnouncedKey = "runs_announced";
constexpr const char* kRunsMissingKey = "runs_missing";

// Keys the recorder writes itself; a program header may not override them.
const std::set<std::string, std::less<>> kReservedKeys = {meta_key::sample_period_s,
                                                          meta_key::start_time,
                                                          meta_key::start_period,
                                                          meta_key::ini_sha256,
                                                          meta_key::channels,
                                                          meta_key::module,
                                                          meta_key::module_channels,
                                                          meta_key::module_depth,
                                                          meta_key::overruns,
                                                          meta_key::gaps,
                                                          meta_key::lost_samples,
                                                          meta_key::rows,
                                                          meta_key::runs,
                                                          meta_key::end_period,
                                                          meta_key::program,
                                                          meta_key::ring_high_water,
                                                          meta_key::recorder,
                                                          meta_key::stop_reason,
                                                          kRunsAnnouncedKey,
                                                          kRunsMissingKey};

}  // namespace

bool recorder_key(std::string_view key) {
  return kReservedKeys.count(key) > 0;
}

namespace {

std::string format_seconds(double s) {
  return fmt::format("{:.9g}", s);
}

class Loop {
 public:
  Loop(circlog::Consumer& ring, const RecordRequest& options, Environment& env, std::FILE* log,
       std::FILE* progress)
      : ring_(ring),
        h_(ring.header()),
        options_(options),
        env_(env),
        log_(log),
        started_s_(env.monotonic_s()),
        progress_(progress ? progress : log, "circlog-record",
                  is_terminal(progress ? progress : log), started_s_) {}

  Summary run(std::int32_t pid);

 private:
  void wait_for_servo();
  void claim(std::int32_t pid);
  std::unique_ptr<TraceWriter> open_writer(const std::vector<std::string>& names);
  std::size_t drain(TraceWriter& writer);
  void note_gap(std::uint64_t lost, std::uint64_t period, bool at_end);
  void track_run(bool marker, std::int32_t segment, bool run_start);
  bool every_announced_run_recorded() const;
  // The first announced run (in program order) not yet recorded whole.
  std::size_t next_missing_run() const;
  std::vector<std::string> missing_runs() const;
  const char* should_stop();
  void wait_for_producer_to_see_release();
  std::string status(const TraceWriter& writer) const;
  void flush_live(TraceWriter& writer);

  circlog::Consumer& ring_;
  const circlog::SharedHeader& h_;
  const RecordRequest& options_;
  Environment& env_;
  std::FILE* log_;

  double period_s_ = 0.0;
  std::uint64_t seq0_ = 0;
  std::uint64_t overruns0_ = 0;
  std::uint64_t start_period_ = 0;
  std::uint64_t expected_seq_ = 0;
  std::uint64_t last_active_period_ = 0;
  std::uint64_t last_periods_ = 0;
  double last_progress_s_ = 0.0;
  double last_live_s_ = 0.0;
  bool live_error_said_ = false;
  bool seen_marker_ = false;
  bool reloaded_ = false;
  // The run being read (marker set), and whether its start was recorded: enable rose, or
  // the segment changed while enabled. Segment ids seen, and those recorded whole.
  bool in_run_ = false;
  std::int32_t run_segment_ = 0;
  bool run_start_recorded_ = false;
  std::set<std::int32_t> runs_seen_;
  std::set<std::int32_t> runs_whole_;
  std::vector<unsigned char> buffer_;
  std::vector<double> row_;
  Summary summary_;
  std::uint64_t gap_messages_ = 0;
  // What has been seen so far, on a terminal (log_ is one): cleared before each message.
  double started_s_;
  ProgressLine progress_;
};

void Loop::wait_for_servo() {
  const std::uint64_t p0 = h_.periods.load(std::memory_order_acquire);
  const double t0 = env_.monotonic_s();
  while (h_.periods.load(std::memory_order_acquire) == p0 ||
         h_.period_ns.load(std::memory_order_acquire) == 0) {
    if (env_.stop_requested()) throw HalError("interrupted while waiting for the servo thread");
    if (env_.monotonic_s() - t0 > kServoStartTimeout_s) {
      throw HalError(
          "circlog.0 is loaded but its function does not run: 'addf circlog.0 servo-thread' "
          "(after the functions that compute its inputs) and start the threads");
    }
    env_.sleep(0.01);
  }
  period_s_ = static_cast<double>(h_.period_ns.load(std::memory_order_acquire)) * 1e-9;
}

void Loop::claim(std::int32_t pid) {
  // Before claiming, the producer does not touch these: they are this session's baseline.
  seq0_ = h_.seq_next.load(std::memory_order_acquire);
  overruns0_ = h_.overruns.load(std::memory_order_acquire);
  const int other = ring_.claim(pid);
  if (other == 0) return;
  if (other > 0 && !env_.process_alive(other) && ring_.steal(other, pid)) {
    progress_.clear();
    std::fprintf(log_, "circlog-record: took over circlog.0 from process %d, which has died\n",
                 other);
    return;
  }
  throw HalError(fmt::format("circlog.0 is already being recorded by process {}", std::abs(other)));
}

std::unique_ptr<TraceWriter> Loop::open_writer(const std::vector<std::string>& names) {
  TraceMetadata meta;
  meta.set(meta_key::recorder, "circlog-record");
  meta.set(meta_key::source, "circlog.0");
  meta.set(meta_key::sample_period_s, format_seconds(period_s_));
  meta.set(meta_key::start_time, env_.utc_now_iso8601());
  meta.set(meta_key::start_period, std::to_string(start_period_));
  meta.set(meta_key::channels, join(names));
  for (const auto& [name, text] : options_.descriptions)
    meta.set(meta_key::channel_prefix + name, text);
  meta.set(meta_key::module_channels, std::to_string(ring_.channels()));
  meta.set(meta_key::module_depth, std::to_string(ring_.depth()));
  if (!options_.ini.empty()) record_ini_provenance(meta, options_.ini);
  if (!options_.program.empty()) {
    meta.set(meta_key::program, options_.program);
    for (const auto& [key, value] : options_.program_plan.header) {
      const bool given = std::any_of(options_.conditions.begin(), options_.conditions.end(),
                                     [&k = key](const auto& c) { return c.first == k; });
      if (given) continue;  // the command line states it
      if (kReservedKeys.count(key) || key.rfind(meta_key::channel_prefix, 0) == 0) {
        progress_.clear();
        std::fprintf(log_, "circlog-record: %s: header key '%s' is the recorder's own; skipped\n",
                     options_.program.c_str(), key.c_str());
        continue;
      }
      meta.set(key, value);
    }
  }

  for (const auto& [key, value] : options_.conditions) meta.set(key, value);

  std::vector<TraceColumn> columns;
  columns.push_back({column_name::t, ColumnKind::real, 9});
  columns.push_back({column_name::period, ColumnKind::integer, 0});
  for (const auto& n : names) columns.push_back({n, ColumnKind::real, options_.decimals});
  columns.push_back({column_name::marker, ColumnKind::integer, 0});
  columns.push_back({column_name::segment, ColumnKind::integer, 0});
  return std::make_unique<TraceWriter>(options_.output, meta, std::move(columns));
}

void Loop::note_gap(std::uint64_t lost, std::uint64_t period, bool at_end) {
  ++summary_.gaps;
  summary_.lost += lost;
  if (gap_messages_ <= 20) progress_.clear();
  if (++gap_messages_ <= 20) {
    if (at_end) {
      std::fprintf(log_, "circlog-record: gap: %llu record(s) lost after the last one received\n",
                   static_cast<unsigned long long>(lost));
    } else {
      std::fprintf(log_, "circlog-record: gap: %llu record(s) lost before period %llu\n",
                   static_cast<unsigned long long>(lost), static_cast<unsigned long long>(period));
    }
  } else if (gap_messages_ == 21) {
    std::fprintf(log_, "circlog-record: more gaps; the totals follow at the end\n");
  }
}

std::size_t Loop::drain(TraceWriter& writer) {
  constexpr std::size_t kBatch = 1024;
  const std::size_t stride = ring_.record_size();
  const int channels = ring_.channels();
  std::size_t total = 0;
  for (;;) {
    const std::size_t n = ring_.read(buffer_.data(), kBatch);
    for (std::size_t i = 0; i < n; ++i) {
      const auto* rec = reinterpret_cast<const circlog::RecordHead*>(buffer_.data() + i * stride);
      if (rec->seq != expected_seq_) note_gap(rec->seq - expected_seq_, rec->period, false);
      expected_seq_ = rec->seq + 1;
      const bool marker = (rec->flags & circlog::kMarker) != 0;
      track_run(marker, rec->segment, (rec->flags & circlog::kRunStart) != 0);
      if (marker && ((rec->flags & circlog::kRunStart) != 0 || !seen_marker_)) ++summary_.runs;
      if (marker) {
        seen_marker_ = true;
        last_active_period_ = std::max(last_active_period_, rec->period + 1);
      }
      row_[0] = static_cast<double>(rec->period) * period_s_;
      row_[1] = static_cast<double>(rec->period);
      const double* values = circlog::record_values(rec);
      for (int c = 0; c < channels; ++c) row_[2 + c] = values[c];
      row_[2 + channels] = marker ? 1.0 : 0.0;
      row_[3 + channels] = rec->segment;
      writer.write_row(row_.data());
    }
    total += n;
    if (n < kBatch) return total;
  }
}

void Loop::track_run(bool marker, std::int32_t segment, bool run_start) {
  bool boundary = false;
  if (in_run_ && (!marker || segment != run_segment_)) {
    if (run_start_recorded_) runs_whole_.insert(run_segment_);
    in_run_ = false;
    boundary = marker;  // the segment changed while enabled: the next run starts here
  }
  if (marker && !in_run_) {
    in_run_ = true;
    run_segment_ = segment;
    run_start_recorded_ = run_start || boundary;
    runs_seen_.insert(segment);
  }
}

std::size_t Loop::next_missing_run() const {
  const auto& runs = options_.program_plan.runs;
  std::size_t k = 0;
  while (k < runs.size() && runs_whole_.count(runs[k].segment_id)) ++k;
  return k;
}

bool Loop::every_announced_run_recorded() const {
  return std::all_of(options_.program_plan.runs.begin(), options_.program_plan.runs.end(),
                     [this](const AnnouncedRun& r) { return runs_whole_.count(r.segment_id); });
}

std::vector<std::string> Loop::missing_runs() const {
  std::vector<std::string> out;
  for (const AnnouncedRun& r : options_.program_plan.runs) {
    if (runs_whole_.count(r.segment_id)) continue;
    out.push_back(fmt::format("{} ({}) {}", r.segment_id, r.label,
                              runs_seen_.count(r.segment_id) ? "incomplete" : "not recorded"));
  }
  return out;
}

const char* Loop::should_stop() {
  if (env_.stop_requested()) return "signal";
  const std::uint64_t periods = h_.periods.load(std::memory_order_acquire);
  const double now = env_.monotonic_s();
  if (periods < last_periods_) {
    reloaded_ = true;
    return "circlog was reloaded";
  }
  if (periods != last_periods_) {
    last_periods_ = periods;
    last_progress_s_ = now;
  } else if (now - last_progress_s_ > kServoStallTimeout_s) {
    return "servo thread stopped";
  }
  if (h_.enabled.load(std::memory_order_acquire) != 0) last_active_period_ = periods;
  if (options_.duration_s &&
      static_cast<double>(periods - start_period_) * period_s_ >= *options_.duration_s) {
    return "duration";
  }
  // Idle only counts once every run the program announced is in: the pauses between a
  // program's runs (a ballbar's feed-out and feed-in, the way back of a one-direction sweep)
  // can be longer than --until-idle. With a run still missing, a longer silence means the
  // program ended without it.
  if (options_.idle_s && seen_marker_ && h_.enabled.load(std::memory_order_acquire) == 0 &&
      periods > last_active_period_) {
    const double idle_s = static_cast<double>(periods - last_active_period_) * period_s_;
    if (every_announced_run_recorded()) {
      if (idle_s >= *options_.idle_s) return "idle";
    } else if (idle_s >= std::max(*options_.idle_s, run_wait_s(options_, next_missing_run()))) {
      return "idle with runs missing";
    }
  }
  return nullptr;
}

void Loop::wait_for_producer_to_see_release() {
  // A servo period that loaded the reader before release() may still write one record;
  // two more periods make sure it has finished.
  const std::uint64_t p = h_.periods.load(std::memory_order_acquire);
  const double t0 = env_.monotonic_s();
  while (!reloaded_ && h_.periods.load(std::memory_order_acquire) < p + 2 &&
         env_.monotonic_s() - t0 < kReleaseSettle_s) {
    env_.sleep(std::min(options_.poll_s, 0.001));
  }
}

Summary Loop::run(std::int32_t pid) {
  wait_for_servo();
  std::vector<std::string> names = options_.columns;
  if (names.empty()) {
    for (int i = 0; i < ring_.channels(); ++i) names.push_back(fmt::format("in-{:02d}", i));
  } else if (static_cast<int>(names.size()) != ring_.channels()) {
    throw UsageError(fmt::format("--columns names {} channel(s) but circlog.0 has {}", names.size(),
                                 ring_.channels()));
  }
  for (const auto& [name, text] : options_.descriptions) {
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      throw UsageError(fmt::format("--describe {}: no such channel", name));
    }
  }
  buffer_.resize(1024 * ring_.record_size());
  row_.resize(static_cast<std::size_t>(ring_.channels()) + 4);

  claim(pid);
  expected_seq_ = seq0_;
  start_period_ = h_.periods.load(std::memory_order_acquire);
  last_periods_ = start_period_;
  last_active_period_ = start_period_;
  last_progress_s_ = env_.monotonic_s();
  std::unique_ptr<TraceWriter> writer;
  try {
    writer = open_writer(names);
    if (!options_.live.empty()) writer->live_copy(options_.live);
  } catch (...) {
    ring_.release();
    throw;
  }

  const char* reason = nullptr;
  try {
    for (;;) {
      // Check before draining, so everything published up to the decision is written.
      reason = should_stop();
      const std::size_t n = drain(*writer);
      if (progress_.enabled()) progress_.update(env_.monotonic_s(), status(*writer));
      flush_live(*writer);
      if (reason) break;
      if (n == 0) env_.sleep(options_.poll_s);
    }
  } catch (...) {
    ring_.release();
    throw;
  }
  ring_.release();
  wait_for_producer_to_see_release();
  drain(*writer);

  const std::uint64_t seq_end = h_.seq_next.load(std::memory_order_acquire);
  if (!reloaded_ && seq_end > expected_seq_) note_gap(seq_end - expected_seq_, 0, true);
  summary_.overruns = reloaded_ ? 0 : h_.overruns.load(std::memory_order_acquire) - overruns0_;
  summary_.rows = writer->rows_written();
  summary_.stop_reason = reason;
  summary_.missing_runs = missing_runs();

  writer->add_trailer(meta_key::rows, std::to_string(summary_.rows));
  writer->add_trailer(meta_key::runs, std::to_string(summary_.runs));
  writer->add_trailer(meta_key::end_period, std::to_string(last_periods_));
  writer->add_trailer(meta_key::overruns, std::to_string(summary_.overruns));
  writer->add_trailer(meta_key::gaps, std::to_string(summary_.gaps));
  writer->add_trailer(meta_key::lost_samples, std::to_string(summary_.lost));
  writer->add_trailer(meta_key::ring_high_water,
                      std::to_string(h_.high_water.load(std::memory_order_acquire)));
  writer->add_trailer(meta_key::stop_reason, summary_.stop_reason);
  if (!options_.program_plan.runs.empty()) {
    writer->add_trailer(kRunsAnnouncedKey, std::to_string(options_.program_plan.runs.size()));
    writer->add_trailer(kRunsMissingKey, summary_.missing_runs.empty()
                                             ? std::string("none")
                                             : join(summary_.missing_runs, "; "));
  }
  writer->commit();
  progress_.clear();
  return summary_;
}

// "12 s, 12000 samples, 1 run; waiting for run 2 of 3".
// The rows since the last time into the live copy, at most every kLiveFlush_s; a live copy
// that failed is said once and the recording goes on.
void Loop::flush_live(TraceWriter& writer) {
  if (options_.live.empty()) return;
  const double now = env_.monotonic_s();
  if (now - last_live_s_ < kLiveFlush_s) return;
  last_live_s_ = now;
  writer.flush_live();
  if (!writer.live_error().empty() && !live_error_said_) {
    std::fprintf(log_, "circlog-record: warning: %s\n", writer.live_error().c_str());
    live_error_said_ = true;
  }
}

std::string Loop::status(const TraceWriter& writer) const {
  std::string text = fmt::format("{:.0f} s, {} samples, {} run(s)", env_.monotonic_s() - started_s_,
                                 writer.rows_written(), summary_.runs);
  if (summary_.gaps > 0) text += fmt::format(", {} gap(s)", summary_.gaps);
  const std::vector<AnnouncedRun>& announced = options_.program_plan.runs;
  const auto position = [&announced](auto&& is) -> std::size_t {
    const auto it = std::find_if(announced.begin(), announced.end(), is);
    return it == announced.end() ? 0 : static_cast<std::size_t>(it - announced.begin()) + 1;
  };
  if (in_run_) {
    const std::size_t k =
        position([this](const AnnouncedRun& r) { return r.segment_id == run_segment_; });
    return text + (k > 0 ? fmt::format("; recording run {} of {}", k, announced.size())
                         : fmt::format("; recording run {}", summary_.runs));
  }
  if (!announced.empty()) {
    const std::size_t k =
        position([this](const AnnouncedRun& r) { return runs_whole_.count(r.segment_id) == 0; });
    return text + (k > 0
                       ? fmt::format("; waiting for run {} of {}", k, announced.size())
                       : fmt::format("; all {} runs recorded, waiting for idle", announced.size()));
  }
  return text + (seen_marker_ ? "; waiting for the next run" : "; waiting for the first run");
}

}  // namespace

std::FILE* open_progress_terminal(const std::string& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
  if (fd < 0 || ::isatty(fd) != 1) {
    if (fd >= 0) ::close(fd);
    throw UsageError(fmt::format("--progress-to {}: not a terminal", path));
  }
  std::FILE* stream = ::fdopen(fd, "w");
  if (stream == nullptr) {
    ::close(fd);
    throw UsageError(fmt::format("--progress-to {}: cannot be written", path));
  }
  return stream;
}

Summary record(circlog::Consumer& ring, std::int32_t pid, const RecordRequest& options,
               Environment& env, std::FILE* log, std::FILE* progress) {
  Loop loop(ring, options, env, log, progress);
  return loop.run(pid);
}

}  // namespace circtest::circlog_record
