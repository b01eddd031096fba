// TraceWriter's live copy: the text form of the trace, growing at each flush_live(), for a
// reader that follows a recording (the QtVCP panel). Checked against the committed trace.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <string>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/core/trace.hpp"
#include "scratch.hpp"

using namespace circtest;
using circtest::testing::ScratchDir;
using circtest::testing::slurp;

namespace {

TraceMetadata header() {
  TraceMetadata m;
  m.set("units", "mm");
  m.set("sample_period_s", "0.001");
  return m;
}

std::vector<TraceColumn> columns() {
  return {{"t", ColumnKind::real, 6}, {"period", ColumnKind::integer}, {"x", ColumnKind::real, 6}};
}

void write_rows(TraceWriter& w, int from, int to) {
  for (int i = from; i < to; ++i) {
    const double row[3] = {i * 0.001, static_cast<double>(i), 75.0 * std::cos(i * 0.01)};
    w.write_row(row);
  }
}

}  // namespace

// Rows reach the live copy at each flush_live(), not before; after commit it holds the trace's
// text byte for byte, also when the trace itself is binary (.ctb).
TEST(TraceLive, GrowsAtEachFlushAndEndsAsTheTracesText) {
  for (const std::string name : {"trace.csv", "trace.ctb"}) {
    SCOPED_TRACE(name);
    ScratchDir s;
    TraceWriter w(s.file(name), header(), columns());
    w.live_copy(s.file("live.csv"));
    const std::string head = slurp(s.file("live.csv"));
    EXPECT_EQ(head, "# units: mm\n# sample_period_s: 0.001\nt,period,x\n");
    write_rows(w, 0, 500);
    EXPECT_EQ(slurp(s.file("live.csv")), head);  // nothing before flush_live()
    w.flush_live();
    const std::string first = slurp(s.file("live.csv"));
    EXPECT_EQ(std::count(first.begin(), first.end(), '\n'), 3 + 500);
    write_rows(w, 500, 1200);
    w.flush_live();
    const std::string second = slurp(s.file("live.csv"));
    EXPECT_EQ(std::count(second.begin(), second.end(), '\n'), 3 + 1200);
    w.add_trailer("rows", "1200");
    w.commit();
    EXPECT_TRUE(w.live_error().empty()) << w.live_error();
    const Trace live = read_trace(s.file("live.csv"));
    const Trace trace = read_trace(s.file(name));
    ASSERT_EQ(live.rows(), 1200u);
    ASSERT_EQ(trace.rows(), 1200u);
    ASSERT_NE(live.metadata.find("rows"), nullptr);
    EXPECT_EQ(*live.metadata.find("rows"), "1200");
    for (std::size_t c = 0; c < 3; ++c) {
      for (std::size_t r = 0; r < live.rows(); r += 97) {
        EXPECT_NEAR(live.values[c][r], trace.values[c][r], 5e-7) << c << " " << r;
      }
    }
    if (name == "trace.csv") {
      EXPECT_EQ(slurp(s.file("live.csv")), slurp(s.file(name)));
    }
  }
}

// The live copy follows the output-path rules: a FIFO or a directory is never replaced, and a
// copy started after the first row is refused; a failing live write stops the copy, not the
// trace.
TEST(TraceLive, RefusesWhatIsNoRegularFileAndAFailureStopsOnlyTheCopy) {
  ScratchDir s;
  ASSERT_EQ(::mkfifo(s.file("fifo").c_str(), 0644), 0);
  std::filesystem::create_directory(s.file("dir"));
  for (const std::string bad : {"fifo", "dir"}) {
    TraceWriter w(s.file("t.csv"), header(), columns());
    EXPECT_THROW(w.live_copy(s.file(bad)), IoError) << bad;
  }
  {
    TraceWriter w(s.file("t.csv"), header(), columns());
    write_rows(w, 0, 1);
    EXPECT_THROW(w.live_copy(s.file("late.csv")), IoError);
  }
  // A live write beyond the file-size limit (EFBIG, SIGXFSZ ignored) stops the copy with a
  // reason; the trace, written after the limit is lifted again, is whole.
  TraceWriter w(s.file("t.csv"), header(), columns());
  w.live_copy(s.file("live.csv"));
  rlimit old{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto previous = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = old;
  small.rlim_cur = 4096;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  write_rows(w, 0, 1000);
  w.flush_live();
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &old), 0);
  std::signal(SIGXFSZ, previous);
  EXPECT_NE(w.live_error().find("live.csv: write failed"), std::string::npos) << w.live_error();
  write_rows(w, 1000, 1100);
  w.flush_live();  // stopped: no further write
  w.commit();
  EXPECT_EQ(read_trace(s.file("t.csv")).rows(), 1100u);
  EXPECT_LE(std::filesystem::file_size(s.file("live.csv")), 4096u);
}
