#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/trace.hpp"

using namespace circtest;

namespace {

std::string message_of(const std::string& text, const TraceReadOptions& o = {}) {
  try {
    parse_trace(text, "in.csv", o);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

ExitCode code_of(const std::string& text, const TraceReadOptions& o = {}) {
  try {
    parse_trace(text, "in.csv", o);
  } catch (const Error& e) {
    return e.code();
  }
  return ExitCode::ok;
}

std::filesystem::path temp_dir() {
  auto p = std::filesystem::temp_directory_path() /
           ("circtest-core-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p;
}

}  // namespace

TEST(TraceReader, ReadsMetadataHeaderAndRows) {
  const Trace t = parse_trace(
      "# plane: XY\n# radius_mm: 75\n# a comment without colon\n"
      "t,x,y,unknown\n0,75,0,9\n0.001,74.9,0.5,9\r\n\n0.002,\"74.8\",1.0,9\n# overruns: 0\n",
      "in.csv");
  ASSERT_EQ(t.rows(), 3u);
  EXPECT_EQ(t.columns.size(), 4u);
  EXPECT_EQ(*t.metadata.find("plane"), "XY");
  EXPECT_DOUBLE_EQ(*t.metadata.number("radius_mm"), 75.0);
  EXPECT_EQ(*t.metadata.find("overruns"), "0");
  EXPECT_EQ(t.header_line, 4u);
  EXPECT_EQ(t.line_of_row[2], 8u);
  EXPECT_DOUBLE_EQ((*t.column("x"))[2], 74.8);
  EXPECT_DOUBLE_EQ((*t.column("y"))[1], 0.5);
}

TEST(TraceReader, KeepsOnlyWantedColumnsAndIgnoresUnknownOnes) {
  TraceReadOptions o;
  o.keep = {"x", "y"};
  const Trace t = parse_trace("x,junk,y\n1,abc,2\n", "in.csv", o);
  ASSERT_EQ(t.columns.size(), 2u);
  EXPECT_DOUBLE_EQ((*t.column("y"))[0], 2.0);
}

TEST(TraceReader, LaterMetadataWins) {
  const Trace t = parse_trace("# overruns: 0\nx\n1\n# overruns: 5\n", "in.csv");
  EXPECT_EQ(*t.metadata.find("overruns"), "5");
}

TEST(TraceReaderErrors, EmptyFile) {
  EXPECT_EQ(message_of(""), "in.csv:1: empty file: expected a header row of column names");
  EXPECT_EQ(code_of(""), ExitCode::parse);
  EXPECT_EQ(message_of("# only: metadata\n"),
            "in.csv:1: no header row: expected a line of column names");
}

TEST(TraceReaderErrors, MissingColumn) {
  TraceReadOptions o;
  o.required = {"t", "x"};
  EXPECT_EQ(message_of("# a: b\nx,y\n1,2\n", o),
            "in.csv:2: missing column 't': expected it in the header (found: x,y)");
}

TEST(TraceReaderErrors, NonNumber) {
  EXPECT_EQ(message_of("t,x\n0,1\n0.1,abc\n"),
            "in.csv:3: column 'x': expected a number, got 'abc'");
  EXPECT_EQ(message_of("t,x\n0,1\n0.1,1.5.2\n"),
            "in.csv:3: column 'x': expected a number, got '1.5.2'");
  EXPECT_EQ(message_of("t,x\n0,1\n0.1,\n"), "in.csv:3: column 'x': expected a number, got ''");
}

TEST(TraceReaderErrors, NanAndInf) {
  EXPECT_EQ(message_of("t,x\n0,nan\n"),
            "in.csv:2: column 'x': expected a finite number, got 'nan'");
  EXPECT_EQ(message_of("t,x\n0,1\n1,-inf\n"),
            "in.csv:3: column 'x': expected a finite number, got '-inf'");
}

TEST(TraceReaderErrors, TimeGoingBackwards) {
  EXPECT_EQ(message_of("t,x\n0,1\n0.002,1\n0.001,1\n"),
            "in.csv:4: time goes backwards: t = 0.001 after t = 0.002; expected non-decreasing "
            "time");
  EXPECT_EQ(code_of("t,x\n0,1\n0.002,1\n0.001,1\n"), ExitCode::data);
}

TEST(TraceReaderErrors, WrongFieldCount) {
  EXPECT_EQ(message_of("t,x,y\n0,1,2\n0.1,1\n"),
            "in.csv:3: expected 3 fields as in the header (line 1), got 2");
  EXPECT_EQ(message_of("t,x,y\n0,1,2,3\n"),
            "in.csv:2: expected 3 fields as in the header (line 1), got 4");
}

TEST(TraceReaderErrors, BrokenQuoting) {
  EXPECT_EQ(message_of("t,x\n0,\"1.0\n"),
            "in.csv:2: field 2: unterminated quoted field: expected a closing '\"'");
  EXPECT_EQ(message_of("\"t,x\n0,1\n"),
            "in.csv:1: field 1: unterminated quoted field: expected a closing '\"'");
  EXPECT_EQ(message_of("t,x\n0,1\"2\"\n"),
            "in.csv:2: field 2: unexpected '\"' inside an unquoted field");
}

TEST(TraceReaderErrors, DuplicateColumn) {
  EXPECT_EQ(message_of("x,y,x\n1,2,3\n"), "in.csv:1: header: duplicate column 'x'");
}

TEST(TraceReaderErrors, MetadataNumber) {
  const Trace t = parse_trace("# radius_mm: 7o\nx\n1\n", "in.csv");
  try {
    t.metadata.number("radius_mm", t.source);
    FAIL() << "expected an error";
  } catch (const ParseError& e) {
    EXPECT_STREQ(e.what(), "in.csv:1: metadata 'radius_mm': expected a finite number, got '7o'");
  }
}

TEST(TraceFile, MissingFileIsAnIoError) {
  try {
    read_trace("/nonexistent/trace.csv");
    FAIL();
  } catch (const IoError& e) {
    EXPECT_EQ(e.code(), ExitCode::io);
    EXPECT_NE(std::string(e.what()).find("/nonexistent/trace.csv: cannot open"), std::string::npos);
  }
}

TEST(TraceFile, WriterRoundTripsThroughTheReaderBlockBoundaries) {
  const auto dir = temp_dir();
  const std::string path = (dir / "t.csv").string();
  TraceMetadata md;
  md.set("plane", "XY");
  std::vector<TraceColumn> cols = {{"t"}, {"x"}, {"y"}, {"segment", ColumnKind::integer}};
  const std::size_t n = 200000;  // several read blocks
  {
    TraceWriter w(path, md, cols);
    for (std::size_t i = 0; i < n; ++i) {
      const double row[4] = {i * 1e-3, 75.0 * std::cos(i * 1e-4), 75.0 * std::sin(i * 1e-4),
                             static_cast<double>(i / 1000)};
      w.write_row(row);
    }
    EXPECT_FALSE(std::filesystem::exists(path)) << "visible before commit";
    w.add_trailer("rows", std::to_string(n));
    w.commit();
  }
  EXPECT_FALSE(std::filesystem::exists(path + ".part"));
  const Trace t = read_trace(path);
  ASSERT_EQ(t.rows(), n);
  EXPECT_EQ(*t.metadata.find("rows"), std::to_string(n));
  for (std::size_t i = 0; i < n; i += 9973) {
    EXPECT_NEAR((*t.column("x"))[i], 75.0 * std::cos(i * 1e-4), 5e-7);
    EXPECT_EQ((*t.column("segment"))[i], static_cast<double>(i / 1000));
    EXPECT_EQ(t.line_of_row[i], i + 3);
  }
  std::filesystem::remove_all(dir);
}

TEST(TraceFile, UncommittedWriterLeavesNothing) {
  const auto dir = temp_dir();
  const std::string path = (dir / "t.csv").string();
  {
    TraceWriter w(path, {}, {{"x"}});
    const double v = 1.0;
    w.write_row(&v);
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_FALSE(std::filesystem::exists(path + ".part"));
  std::filesystem::remove_all(dir);
}

TEST(AtomicFile, ReplacesAndKeepsBackup) {
  const auto dir = temp_dir();
  const std::string path = (dir / "machine.ini").string();
  write_file_atomic(path, "old\n");
  write_file_atomic(path, "new\n", {.keep_backup = true});
  EXPECT_EQ(read_file(path), "new\n");
  EXPECT_EQ(read_file(path + ".bak"), "old\n");
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 2u) << "a temporary file was left behind";
  std::filesystem::remove_all(dir);
}

TEST(AtomicFile, FailureLeavesTheOriginalUntouched) {
  EXPECT_THROW(write_file_atomic("/nonexistent-dir/x.ini", "x"), IoError);
}

namespace {

// Writes a binary trace with the given rows (t, x) and returns its path.
std::string write_binary(const std::filesystem::path& dir,
                         const std::vector<std::pair<double, double>>& rows) {
  const std::string path = (dir / "t.ctb").string();
  TraceMetadata md;
  md.set("plane", "XY");
  TraceWriter w(path, md, {{"t"}, {"x"}});
  for (const auto& [t, x] : rows) {
    const double row[2] = {t, x};
    w.write_row(row);
  }
  w.add_trailer("overruns", "3");
  w.commit();
  return path;
}

}  // namespace

TEST(BinaryTrace, RoundTripsBitExactWithMetadataAndTrailer) {
  const auto dir = temp_dir();
  const std::string path = (dir / "t.ctb").string();
  TraceMetadata md;
  md.set("radius_mm", "75");
  const std::size_t n = 100000;  // several read blocks
  {
    TraceWriter w(path, md, {{"t"}, {"x"}, {"y"}, {"marker", ColumnKind::integer}});
    for (std::size_t i = 0; i < n; ++i) {
      const double th = static_cast<double>(i) * 1e-4;
      const double row[4] = {static_cast<double>(i) * 1e-3, 75.0 * std::cos(th) + 1e-9 / 3,
                             75.0 * std::sin(th), 1.0};
      w.write_row(row);
    }
    w.add_trailer("rows", std::to_string(n));
    w.commit();
  }
  TraceReadOptions o;
  o.keep = {"t", "x"};
  const Trace t = read_trace(path, o);
  ASSERT_EQ(t.rows(), n);
  EXPECT_EQ(t.columns, (std::vector<std::string>{"t", "x"}));
  EXPECT_EQ(*t.metadata.find("radius_mm"), "75");
  EXPECT_EQ(*t.metadata.find("rows"), std::to_string(n));
  for (std::size_t i = 0; i < n; i += 7919) {
    const double th = static_cast<double>(i) * 1e-4;
    EXPECT_EQ((*t.column("x"))[i], 75.0 * std::cos(th) + 1e-9 / 3);  // bit exact, unlike text
    EXPECT_EQ(t.line_of_row[i], i + 1);                              // record numbers
  }
  std::filesystem::remove_all(dir);
}

TEST(BinaryTrace, TruncatedFileIsRefused) {
  const auto dir = temp_dir();
  const std::string path = write_binary(dir, {{0.0, 1.0}, {0.001, 2.0}});
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 5);
  try {
    read_trace(path);
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_EQ(std::string(e.what()),
              path + ": binary trace truncated: no footer (expected it to end with \"CTBE\")");
  }
  std::filesystem::remove_all(dir);
}

TEST(BinaryTrace, BadValuesNameTheirRecord) {
  const auto dir = temp_dir();
  std::string path = write_binary(dir, {{0.0, 1.0}, {0.001, std::nan("")}});
  try {
    read_trace(path);
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_EQ(std::string(e.what()),
              path + ": record 2: column 'x': expected a finite number, got 'nan'");
  }
  path = write_binary(dir, {{0.0, 1.0}, {0.002, 1.0}, {0.001, 1.0}});
  try {
    read_trace(path);
    FAIL();
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()),
              path +
                  ": record 3: time goes backwards: t = 0.001 after t = 0.002; expected "
                  "non-decreasing time");
  }
  std::filesystem::remove_all(dir);
}
