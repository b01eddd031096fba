#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/trace.hpp"
#include "scratch.hpp"
#include "stdin_pipe.hpp"

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

// The plane's columns only (keep_for sees the metadata above the header), and a quoted field
// with a comma in a column that is not kept still splits the row right.
TEST(TraceReader, KeepForChoosesColumnsFromTheMetadata) {
  TraceReadOptions o;
  std::string plane_seen;
  o.keep_for = [&](const TraceMetadata& m) {
    plane_seen = m.find("plane") ? *m.find("plane") : "";
    return plane_seen == "ZX" ? std::vector<std::string>{"z", "x"}
                              : std::vector<std::string>{"x", "y"};
  };
  const Trace t = parse_trace("# plane: ZX\nx,note,y,z\n1,\"a,b\",2,3\n4,c,5,6\n", "in.csv", o);
  EXPECT_EQ(plane_seen, "ZX");
  ASSERT_EQ(t.columns, (std::vector<std::string>{"x", "z"}));
  EXPECT_EQ(*t.column("z"), (std::vector<double>{3.0, 6.0}));
  EXPECT_EQ(*t.column("x"), (std::vector<double>{1.0, 4.0}));
  EXPECT_EQ(t.line_of_row, (std::vector<std::uint32_t>{3, 4}));
}

TEST(TraceReader, LaterMetadataWins) {
  const Trace t = parse_trace("# overruns: 0\nx\n1\n# overruns: 5\n", "in.csv");
  EXPECT_EQ(*t.metadata.find("overruns"), "5");
}

// Every key of a large set of metadata (a hostile trace of 200,000 keys, a key given three
// times) is found at its last value and line, and listed once where it first appears.
TEST(TraceReader, ManyMetadataKeysKeepTheirLastValueAndFirstPlace) {
  constexpr std::size_t kKeys = 200000;
  std::string text;
  text.reserve(kKeys * 24);
  text += "# twice: first\n";
  for (std::size_t i = 0; i < kKeys; ++i) text += fmt::format("# key{}: value {}\n", i, i);
  text += "# twice: second\nt,x\n0,1\n# key7: trailer\n# twice: third\n";
  const Trace t = parse_trace(text, "in.csv");
  EXPECT_EQ(t.metadata.entries().size(), kKeys + 4);
  EXPECT_EQ(*t.metadata.find("key0"), "value 0");
  EXPECT_EQ(*t.metadata.find("key199999"), "value 199999");
  EXPECT_EQ(*t.metadata.find("key7"), "trailer");
  EXPECT_EQ(t.metadata.line_of("key7"), kKeys + 5);
  EXPECT_EQ(t.metadata.line_of("key123456"), 123458u);
  EXPECT_EQ(*t.metadata.find("twice"), "third");
  EXPECT_EQ(t.metadata.find("key200000"), nullptr);
  EXPECT_EQ(t.metadata.line_of("absent"), 0u);
  const std::vector<std::size_t> distinct = t.metadata.distinct();
  ASSERT_EQ(distinct.size(), kKeys + 1);
  // "twice" first (where it first stood) with its last value, then the keys in file order.
  EXPECT_EQ(t.metadata.entries()[distinct[0]].first, "twice");
  EXPECT_EQ(t.metadata.entries()[distinct[0]].second, "third");
  EXPECT_EQ(t.metadata.entries()[distinct[8]].first, "key7");
  EXPECT_EQ(t.metadata.entries()[distinct[8]].second, "trailer");
  EXPECT_EQ(t.metadata.entries()[distinct[kKeys]].first, "key199999");
}

// A copy keeps its own index: lookups in it see what was set in it.
TEST(TraceReader, MetadataCopiesLookUpTheirOwnEntries) {
  TraceMetadata a;
  a.set("k", "1");
  TraceMetadata b = a;
  b.set("k", "2");
  b.set("m", "3");
  EXPECT_EQ(*a.find("k"), "1");
  EXPECT_EQ(a.find("m"), nullptr);
  EXPECT_EQ(*b.find("k"), "2");
  EXPECT_EQ(b.distinct().size(), 2u);
}

// A G-code program given as a trace is named as one, by its content (whatever the file is
// called): circgen's header comments, `%`, `;` comments, numbered or plain G/M words.
TEST(TraceReaderErrors, AGCodeProgramIsNamedAsOne) {
  const std::string expected =
      "this is a G-code program, not a trace: run it and record with circlog-record";
  for (const std::string program :
       {"(circtest: generator: circgen 0.1.0)\nG21 G17\n", "%\nG21\n%\n", "; setup\nG0 X0\n",
        "\n\nN10 G1 X5 F300 ; feed\nN20 M2\n", "G21 G17 G90 G91.1 G94 G40 G80\n",
        "# name: value\nM5 M9 (spindle and coolant off)\n", "O100 sub\n", "o100 (sub)\n"}) {
    SCOPED_TRACE(program);
    const std::string m = message_of(program);
    EXPECT_NE(m.find(expected), std::string::npos) << m;
    EXPECT_EQ(m.rfind("in.csv:", 0), 0u) << m;
    EXPECT_EQ(code_of(program), ExitCode::parse);
  }
  // Header rows that only look alike are read as header rows.
  for (const std::string trace :
       {"t,x,y\n0,1,2\n", "x,y\n1,2\n", "g1,m2\n1,2\n", "\"(x)\",y\n1,2\n", "x\n1\n", "G\n1\n"}) {
    SCOPED_TRACE(trace);
    EXPECT_EQ(code_of(trace), ExitCode::ok) << message_of(trace);
  }
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
  // A key the reader does not interpret is checked where it is used.
  const Trace t = parse_trace("# offset_tool_mm: 7o\nx\n1\n", "in.csv");
  try {
    t.metadata.number("offset_tool_mm", t.source);
    FAIL() << "expected an error";
  } catch (const ParseError& e) {
    EXPECT_STREQ(e.what(),
                 "in.csv:1: metadata 'offset_tool_mm': expected a finite number, got '7o'");
  }
}

TEST(TraceReaderErrors, InterpretedMetadataValuesAreCheckedAtTheirLine) {
  struct Case {
    const char* line;
    const char* message;
  };
  for (const Case& c : {
           Case{"radius_mm: -75",
                "metadata 'radius_mm': expected a radius in mm above 0 and at "
                "most 100000, got '-75'"},
           Case{"radius_mm: 0", "metadata 'radius_mm': expected a radius in mm above 0"},
           Case{"diameter_mm: 1e308", "metadata 'diameter_mm': expected a diameter in mm"},
           Case{"diameter_mm: 7o", "got '7o'"},
           Case{"centre_mm: 1,2", "metadata 'centre_mm': expected three numbers x,y,z in mm"},
           Case{"centre_mm: 1,2,nan", "metadata 'centre_mm': expected three numbers"},
           Case{"plane: XZ", "metadata 'plane': expected XY, YZ or ZX, got 'XZ'"},
           Case{"units: furlong", "metadata 'units': expected mm or inch, got 'furlong'"},
           Case{"arc_deg: 0", "metadata 'arc_deg': expected a measured arc in deg above 0"},
           Case{"arc_deg: inf", "metadata 'arc_deg'"},
           Case{"feed_mm_per_min: -500", "metadata 'feed_mm_per_min': expected a feed"},
           Case{"feeds_mm_per_min: 500,,1000", "metadata 'feeds_mm_per_min'"},
           Case{"temperature_machine_C: -300", "metadata 'temperature_machine_C'"},
           Case{"expansion_instrument_per_K: 1e308", "metadata 'expansion_instrument_per_K'"},
           Case{"sample_period_s: 0", "metadata 'sample_period_s'"},
           Case{"rows: 2.5", "metadata 'rows': expected a row count"},
       }) {
    const std::string text = std::string("# generator: test\n# ") + c.line + "\nt,x\n0,1\n";
    EXPECT_EQ(code_of(text), ExitCode::parse) << c.line;
    const std::string m = message_of(text);
    EXPECT_EQ(m.rfind("in.csv:2: ", 0), 0u) << m;
    EXPECT_NE(m.find(c.message), std::string::npos) << m;
  }
  // Good values, case and blanks as the writers give them, pass.
  const Trace t = parse_trace(
      "# radius_mm: 75\n# diameter_mm: 150\n# centre_mm: 0, -12.5,1e2\n# plane: zx\n"
      "# units: inch\n# arc_deg: 360\n# feeds_mm_per_min: 500,1000\n# rows: 1\n"
      "# temperature_machine_C: 20.5\n# expansion_machine_per_K: 1.15e-5\nt,x\n0,1\n",
      "in.csv");
  EXPECT_EQ(t.rows(), 1u);
  // A bad header value later overridden by the trailer still names the header's line.
  EXPECT_EQ(message_of("# arc_deg: -1\nt,x\n0,1\n# arc_deg: 360\n").rfind("in.csv:1: ", 0), 0u);
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
  const circtest::testing::ScratchDir scratch("circtest-core");
  const auto dir = scratch.dir();
  const std::string path = (dir / "t.csv").string();
  TraceMetadata md;
  md.set("plane", "XY");
  std::vector<TraceColumn> cols = {{"t"}, {"x"}, {"y"}, {"segment", ColumnKind::integer}};
  const std::size_t n = 200000;  // several read blocks
  {
    TraceWriter w(path, md, cols);
    for (std::size_t i = 0; i < n; ++i) {
      const double di = static_cast<double>(i);
      const double row[4] = {di * 1e-3, 75.0 * std::cos(di * 1e-4), 75.0 * std::sin(di * 1e-4),
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
    EXPECT_NEAR((*t.column("x"))[i], 75.0 * std::cos(static_cast<double>(i) * 1e-4), 5e-7);
    EXPECT_EQ((*t.column("segment"))[i], static_cast<double>(i / 1000));
    EXPECT_EQ(t.line_of_row[i], i + 3);
  }
  std::filesystem::remove_all(dir);
}

TEST(TraceFile, UncommittedWriterLeavesNothing) {
  const circtest::testing::ScratchDir scratch("circtest-core");
  const auto dir = scratch.dir();
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

TEST(TraceReaderErrors, LineLongerThanTheCap) {
  std::string text = "t,x\n0,1\n" + std::string(kMaxInputLineBytes + 1, '5') + "\n";
  EXPECT_EQ(message_of(text),
            "in.csv:3: line longer than 1048576 bytes (1 MiB): expected one record per line");
  // Exactly at the cap is a line like any other (here a malformed row).
  text = "t,x\n0,1\n" + std::string(kMaxInputLineBytes, '5') + "\n";
  EXPECT_EQ(code_of(text), ExitCode::parse);
  EXPECT_EQ(message_of(text).find("line longer"), std::string::npos);
}

TEST(TraceReader, ByteOrderMarkBeforeMetadataOrHeaderIsSkipped) {
  Trace t = parse_trace("\xEF\xBB\xBF# plane: YZ\nt,x\n0,1\n", "in.csv");
  EXPECT_EQ(*t.metadata.find("plane"), "YZ");
  EXPECT_EQ(t.header_line, 2u);
  t = parse_trace("\xEF\xBB\xBFt,x\n0,1\n", "in.csv");
  EXPECT_EQ(t.columns, (std::vector<std::string>{"t", "x"}));
  // Only at the start of the file: elsewhere it is not a number.
  const std::string bom = "\xEF\xBB\xBF";
  EXPECT_EQ(message_of("t,x\n" + bom + "0,1\n"),
            "in.csv:2: column 't': expected a number, got '" + bom + "0'");
}

TEST(TraceReader, HeaderCheckIsLinearIn200000Names) {
  // Short base-36 names keep the header under the line cap. A quadratic check would take
  // minutes here (2e10 comparisons) and hit the test timeout.
  std::string header, row;
  auto name = [](std::size_t i) {
    std::string s;
    do {
      s += "0123456789abcdefghijklmnopqrstuvwxyz"[i % 36];
      i /= 36;
    } while (i);
    return s;
  };
  const std::size_t n = 200000;
  for (std::size_t i = 0; i < n; ++i) {
    if (i) header += ',';
    header += name(i);
    row += i ? ",1" : "1";
  }
  ASSERT_LT(header.size(), kMaxInputLineBytes);
  TraceReadOptions o;
  o.keep = {name(n - 1)};
  const Trace t = parse_trace(header + "\n" + row + "\n", "in.csv", o);
  EXPECT_EQ(t.rows(), 1u);
  EXPECT_EQ(message_of(header + "," + name(123456) + "\n"),
            "in.csv:1: header: duplicate column '" + name(123456) + "'");
}

TEST(TraceFile, DevicesAndDirectoriesAreRefusedBeforeReading) {
  try {
    read_trace("/dev/zero");
    FAIL() << "read /dev/zero";
  } catch (const IoError& e) {
    EXPECT_STREQ(e.what(), "/dev/zero: is a character device, not a regular file");
  }
  const circtest::testing::ScratchDir scratch("circtest-core");
  const auto dir = scratch.dir();
  try {
    read_trace(dir.string());
    FAIL();
  } catch (const IoError& e) {
    EXPECT_EQ(std::string(e.what()), dir.string() + ": is a directory, not a regular file");
  }
  EXPECT_THROW(read_input_text(dir.string()), IoError);
  std::filesystem::remove_all(dir);
}

TEST(TraceFile, StandardInputIsReadAndItsLinesCapped) {
  {
    circtest::testing::StdinPipe in("# plane: XY\nt,x\n0,1\n0.5,2\n");
    const Trace t = read_trace("-");
    EXPECT_EQ(t.rows(), 2u);
    EXPECT_EQ(t.line_of_row[1], 4u);
  }
  // An endless line (what /dev/zero through a pipe would be): refused at the cap, while only
  // a few MiB have been read.
  circtest::testing::StdinPipe in("t,x\n0,1\n" + std::string(3 * kMaxInputLineBytes, '0'));
  try {
    read_trace("-");
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_EQ(std::string(e.what()),
              "-:3: line longer than 1048576 bytes (1 MiB): expected one record per line");
  }
}

// A FIFO named as a trace is refused unopened (it would wait for a writer).
TEST(TraceFile, AFifoIsRefusedUnopened) {
  const circtest::testing::ScratchDir scratch("circtest-core");
  const std::string fifo = (scratch.dir() / "trace.fifo").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    read_trace(fifo);
    FAIL();
  } catch (const IoError& e) {
    EXPECT_EQ(std::string(e.what()), fifo + ": is a FIFO, not a regular file");
    EXPECT_EQ(e.code(), ExitCode::io);
  }
}
