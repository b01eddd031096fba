#include "recorder.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <boost/program_options.hpp>
#include <cmath>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>

#include "circtest/core/cli.hpp"
#include "circtest/core/conditions.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/sha256.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/core/version.hpp"

namespace circtest::circlog_record {

namespace po = boost::program_options;

namespace {

// How long the recorder waits before it gives up or moves on, in seconds of monotonic time.
// A loaded circlog whose function is not added never counts a period: refuse after this.
constexpr double kServoStartTimeout_s = 5.0;
// A running servo thread counts a period every millisecond or so: this long without one means
// it stopped (LinuxCNC shut down), and the trace ends with that reason.
constexpr double kServoStallTimeout_s = 2.0;
// After release(), at most this long for the two periods that let the writer finish a record.
constexpr double kReleaseSettle_s = 0.5;

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
                                                          meta_key::stop_reason};

const std::set<std::string, std::less<>> kFixedColumns = {
    column_name::t, column_name::period, column_name::marker, column_name::segment};

std::vector<std::string> split_commas(const std::string& text) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(text);
  while (std::getline(in, item, ',')) out.push_back(item);
  if (!text.empty() && text.back() == ',') out.emplace_back();
  return out;
}

bool valid_name(const std::string& name) {
  if (name.empty()) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
  });
}

// circgen's header keys: lowercase snake case. Prose comments such as "(Note: ...)" or
// "(Mode: G17)" are left out.
bool valid_header_key(const std::string& key) {
  if (key.empty() || !std::islower(static_cast<unsigned char>(key[0]))) return false;
  return std::all_of(key.begin(), key.end(), [](char c) {
    return std::islower(static_cast<unsigned char>(c)) ||
           std::isdigit(static_cast<unsigned char>(c)) || c == '_' || c == '.';
  });
}

std::string format_seconds(double s) {
  return fmt::format("{:.9g}", s);
}

}  // namespace

std::optional<Options> parse_options(int argc, const char* const* argv, std::FILE* out) {
  Options o;
  std::string columns;
  std::vector<std::string> describe;
  double duration = 0.0;
  double idle = 0.0;
  po::options_description desc(
      "circlog-record: writes what the circlog HAL component logs to a trace file.\n"
      "Usage: circlog-record -o FILE [options]\nOptions");
  desc.add_options()("help,h", "print this help")("version", "print the version")(
      "output,o", po::value(&o.output)->value_name("FILE"), "trace file to write (required)")(
      "columns", po::value(&columns)->value_name("NAME,..."),
      "one name per circlog channel, in pin order (default in-00,in-01,...); axis "
      "positions are x,y,z, commanded positions x_cmd,y_cmd,z_cmd")(
      "describe", po::value(&describe)->value_name("NAME=TEXT")->composing(),
      "a description of a channel, written as metadata channel.NAME (repeatable)")(
      "duration", po::value(&duration)->value_name("S"), "stop after S seconds of servo time")(
      "until-idle", po::value(&idle)->value_name("S"),
      "stop once a run was recorded and enable has then stayed false for S seconds (the "
      "program has finished)")(
      "ini", po::value(&o.ini)->value_name("FILE.ini"),
      "the machine's LinuxCNC INI: its path and SHA-256 go into the metadata (ini, ini_sha256), "
      "so circcomp can tell whether a correction was measured on the configuration it edits")(
      "program", po::value(&o.program)->value_name("FILE.ngc"),
      "copy the (key: value) header comments of this G-code program into the metadata")(
      "decimals", po::value(&o.decimals)->value_name("N"),
      "decimals of the channel values (default 6: 1 nm in mm)")(
      "poll", po::value(&o.poll_s)->value_name("S"),
      "sleep between polls of an empty ring (default 0.005)");
  // The test conditions of clauses 4.4 and 6, written as metadata (docs/trace-format.md).
  std::vector<std::string> condition_values(condition_options().size());
  for (std::size_t i = 0; i < condition_options().size(); ++i) {
    const auto& c = condition_options()[i];
    desc.add_options()(c.option, po::value(&condition_values[i])->value_name(c.value_name), c.help);
  }
  po::variables_map vm;
  try {
    refuse_option_placeholders(argc, argv);
    po::store(po::command_line_parser(argc, argv).options(desc).run(), vm);
    po::notify(vm);
  } catch (const po::error& e) {
    throw UsageError(e.what());
  }
  if (vm.count("help")) {
    std::ostringstream text;
    text << desc;
    std::fputs(text.str().c_str(), out);
    return std::nullopt;
  }
  if (vm.count("version")) {
    std::fprintf(out, "%s\n", circtest::version_line("circlog-record").c_str());
    return std::nullopt;
  }
  if (o.output.empty()) throw UsageError("-o FILE is required");
  if (vm.count("duration")) {
    if (!(duration > 0.0) || !std::isfinite(duration)) {
      throw UsageError("--duration must be a positive number of seconds");
    }
    o.duration_s = duration;
  }
  if (vm.count("until-idle")) {
    if (!(idle >= 0.0) || !std::isfinite(idle)) {
      throw UsageError("--until-idle must be a number of seconds >= 0");
    }
    o.idle_s = idle;
  }
  if (o.decimals < 0 || o.decimals > 12) throw UsageError("--decimals must be in 0..12");
  if (!(o.poll_s > 0.0) || o.poll_s > 1.0) throw UsageError("--poll must be in (0, 1] s");
  if (vm.count("columns")) {
    o.columns = split_commas(columns);
    std::set<std::string> seen;
    for (const auto& name : o.columns) {
      if (!valid_name(name)) {
        throw UsageError(fmt::format(
            "--columns: '{}' is not a column name (letters, digits, '_', '-', '.')", name));
      }
      if (kFixedColumns.count(name)) {
        throw UsageError(
            fmt::format("--columns: '{}' is a column circlog-record writes itself", name));
      }
      if (!seen.insert(name).second) {
        throw UsageError(fmt::format("--columns: '{}' is given twice", name));
      }
    }
  }
  for (std::size_t i = 0; i < condition_options().size(); ++i) {
    const auto& c = condition_options()[i];
    if (vm.count(c.option))
      o.conditions.emplace_back(c.key, condition_value(c, condition_values[i]));
  }
  for (const auto& d : describe) {
    const auto eq = d.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw UsageError(fmt::format("--describe '{}': expected NAME=TEXT", d));
    }
    o.descriptions.emplace_back(d.substr(0, eq), d.substr(eq + 1));
  }
  return o;
}

std::vector<std::pair<std::string, std::string>> read_program_header(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw IoError(path, "cannot open the G-code program");
  std::vector<std::pair<std::string, std::string>> out;
  std::string line;
  while (std::getline(in, line)) {
    const std::string s(trim(line));
    if (s.empty() || s == "%") continue;
    if (s.front() != '(' || s.back() != ')') break;  // the first line of code ends the header
    const std::string inner = s.substr(1, s.size() - 2);
    const auto colon = inner.find(':');
    if (colon == std::string::npos) continue;
    std::string key(trim(inner.substr(0, colon)));
    std::string value(trim(inner.substr(colon + 1)));
    // circgen writes "(circtest: key: value)": the prefix marks its lines, the key follows.
    if (key == "circtest") {
      const auto second = value.find(':');
      if (second == std::string::npos) continue;
      key = std::string(trim(value.substr(0, second)));
      value = std::string(trim(value.substr(second + 1)));
    }
    if (!valid_header_key(key)) continue;
    out.emplace_back(std::move(key), std::move(value));
  }
  if (in.bad()) throw IoError(path, "read failed");
  return out;
}

namespace {

class Loop {
 public:
  Loop(circlog::Consumer& ring, const Options& options, Environment& env, std::FILE* log)
      : ring_(ring), h_(ring.header()), options_(options), env_(env), log_(log) {}

  Summary run(std::int32_t pid);

 private:
  void wait_for_servo();
  void claim(std::int32_t pid);
  std::unique_ptr<TraceWriter> open_writer(const std::vector<std::string>& names);
  std::size_t drain(TraceWriter& writer);
  void note_gap(std::uint64_t lost, std::uint64_t period, bool at_end);
  const char* should_stop();
  void wait_for_producer_to_see_release();

  circlog::Consumer& ring_;
  const circlog::SharedHeader& h_;
  const Options& options_;
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
  bool seen_marker_ = false;
  bool reloaded_ = false;
  std::vector<unsigned char> buffer_;
  std::vector<double> row_;
  Summary summary_;
  std::uint64_t gap_messages_ = 0;
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
  if (!options_.ini.empty()) {
    meta.set(meta_key::ini, options_.ini);
    meta.set(meta_key::ini_sha256, sha256_of_file(options_.ini));
  }
  if (!options_.program.empty()) {
    meta.set(meta_key::program, options_.program);
    for (auto& [key, value] : read_program_header(options_.program)) {
      const bool given = std::any_of(options_.conditions.begin(), options_.conditions.end(),
                                     [&k = key](const auto& c) { return c.first == k; });
      if (given) continue;  // the command line states it
      if (kReservedKeys.count(key) || key.rfind(meta_key::channel_prefix, 0) == 0) {
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
  if (options_.idle_s && seen_marker_ && h_.enabled.load(std::memory_order_acquire) == 0 &&
      periods > last_active_period_ &&
      static_cast<double>(periods - last_active_period_) * period_s_ >= *options_.idle_s) {
    return "idle";
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

  writer->add_trailer(meta_key::rows, std::to_string(summary_.rows));
  writer->add_trailer(meta_key::runs, std::to_string(summary_.runs));
  writer->add_trailer(meta_key::end_period, std::to_string(last_periods_));
  writer->add_trailer(meta_key::overruns, std::to_string(summary_.overruns));
  writer->add_trailer(meta_key::gaps, std::to_string(summary_.gaps));
  writer->add_trailer(meta_key::lost_samples, std::to_string(summary_.lost));
  writer->add_trailer(meta_key::ring_high_water,
                      std::to_string(h_.high_water.load(std::memory_order_acquire)));
  writer->add_trailer(meta_key::stop_reason, summary_.stop_reason);
  writer->commit();
  return summary_;
}

}  // namespace

Summary record(circlog::Consumer& ring, std::int32_t pid, const Options& options, Environment& env,
               std::FILE* log) {
  Loop loop(ring, options, env, log);
  return loop.run(pid);
}

}  // namespace circtest::circlog_record
