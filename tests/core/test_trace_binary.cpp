// The binary trace form (.ctb: written, read back bit-exact, refused when cut or bad) and the
// reader's parallel stretches (the same trace as one thread, the first error in file order).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/trace.hpp"
#include "scratch.hpp"

using namespace circtest;

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
  const circtest::testing::ScratchDir scratch("circtest-core");
  const auto dir = scratch.dir();
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
  const circtest::testing::ScratchDir scratch("circtest-core");
  const auto dir = scratch.dir();
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
  const circtest::testing::ScratchDir scratch("circtest-core");
  const auto dir = scratch.dir();
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

// ---------------------------------------------------------------- parallel reading

namespace {

TraceReadOptions threads(unsigned n) {
  TraceReadOptions o;
  o.threads = n;
  o.parallel_min_bytes = 0;  // split even a small text
  return o;
}

// Rows with everything the reader meets: comments and blank lines between rows, CRLF,
// quoted and '+' numbers, blanks around fields, a column that is not kept.
std::string mixed_trace(std::size_t rows) {
  std::string s = "# plane: XY\nt,x,y,note\n";
  for (std::size_t i = 0; i < rows; ++i) {
    const double t = static_cast<double>(i) * 1e-3;
    if (i % 97 == 5) s += "# event_" + std::to_string(i) + ": seen\n";
    if (i % 89 == 7) s += "\n";
    if (i % 13 == 3) {
      s += fmt::format("{:.6f}, \"{:.6f}\" ,+{:.6f},\"7\"\r\n", t, std::cos(t), std::sin(t));
    } else {
      s += fmt::format("{:.6f},{:.6f},{:.6f},{}\n", t, std::cos(t), std::sin(t), i % 5);
    }
  }
  s += "# rows: " + std::to_string(rows);  // no final newline
  return s;
}

std::string error_of(const std::string& text, const TraceReadOptions& o) {
  try {
    parse_trace(text, "in.csv", o);
  } catch (const Error& e) {
    return fmt::format("{} {}", static_cast<int>(e.code()), e.what());
  }
  return "no error";
}

}  // namespace

TEST(TraceParallel, StretchesGiveTheSameTraceAsOneThread) {
  const std::string text = mixed_trace(5000);
  TraceReadOptions keep = threads(1);
  keep.keep = {"t", "x", "y"};
  const Trace one = parse_trace(text, "in.csv", keep);
  for (unsigned n : {2u, 3u, 7u}) {
    TraceReadOptions o = threads(n);
    o.keep = keep.keep;
    const Trace many = parse_trace(text, "in.csv", o);
    ASSERT_EQ(many.rows(), 5000u);
    EXPECT_EQ(many.values, one.values) << n;
    EXPECT_EQ(many.line_of_row, one.line_of_row) << n;
    ASSERT_EQ(many.metadata.entries(), one.metadata.entries()) << n;
    for (std::size_t i = 0; i < one.metadata.entries().size(); ++i) {
      EXPECT_EQ(many.metadata.line_at(i), one.metadata.line_at(i));
    }
  }
  // Independent truth for the line numbers: the row after the header is line 3.
  EXPECT_EQ(one.line_of_row[0], 3u);
  EXPECT_EQ(*one.metadata.find("rows"), "5000");
}

TEST(TraceParallel, AFileReadInBlocksOrInStretchesGivesTheSameTrace) {
  // One thread reads the file in blocks; stretches each read their own part of it. The same
  // trace from all, and the same error.
  const circtest::testing::ScratchDir scratch("circtest-core");
  const std::string path = (scratch.dir() / "mixed.csv").string();
  circtest::testing::spit(path, mixed_trace(20000));
  TraceReadOptions stream = threads(1);
  TraceReadOptions two = threads(2);
  TraceReadOptions seven = threads(7);
  const Trace one = read_trace(path, stream);
  ASSERT_EQ(one.rows(), 20000u);
  for (const TraceReadOptions& o : {two, seven}) {
    const Trace t = read_trace(path, o);
    EXPECT_EQ(t.values, one.values);
    EXPECT_EQ(t.line_of_row, one.line_of_row);
    EXPECT_EQ(t.metadata.entries(), one.metadata.entries());
  }
  // A bad file: the same refusal from one thread and from stretches.
  auto refused = [&](const std::string& text) {
    circtest::testing::spit(path, text);
    std::string first;
    for (const TraceReadOptions& o : {stream, two, seven}) {
      try {
        read_trace(path, o);
        ADD_FAILURE() << "read a bad file";
      } catch (const Error& e) {
        if (first.empty()) first = e.what();
        EXPECT_EQ(e.what(), first);
      }
    }
    return first;
  };
  const std::string number = refused(mixed_trace(20000) + "\n99,2,x,4\n");
  EXPECT_NE(number.find("column 'y': expected a number, got 'x'"), std::string::npos) << number;

  // A line longer than any reader holds, three quarters in (a later stretch's), and time going
  // back where the second half starts: refused at the same line as by one thread.
  const std::string rows = mixed_trace(20000);
  const std::size_t cut = rows.find('\n', rows.size() * 3 / 4) + 1;
  const std::string long_line = refused(
      rows.substr(0, cut) + std::string(std::size_t{2} << 20, '7') + "\n" + rows.substr(cut));
  EXPECT_NE(long_line.find("line longer than"), std::string::npos) << long_line;
  const std::string back =
      refused(mixed_trace(10000) + "\n" +
              mixed_trace(10000).substr(std::string("# plane: XY\nt,x,y,note\n").size()));
  EXPECT_NE(back.find("time goes backwards"), std::string::npos) << back;
}

TEST(TraceParallel, TheFirstErrorInFileOrderWinsWithItsLine) {
  const std::string good = mixed_trace(3000);
  std::vector<std::string> bad;
  // Breaks placed near the start, the middle and the end, alone and together.
  auto replace_line = [&](std::string s, std::size_t line, const std::string& with) {
    std::size_t pos = 0;
    for (std::size_t l = 1; l < line; ++l) pos = s.find('\n', pos) + 1;
    const std::size_t end = s.find('\n', pos);
    return s.replace(pos, end - pos, with);
  };
  bad.push_back(replace_line(good, 2500, "2.5,1,abc,0"));
  bad.push_back(replace_line(replace_line(good, 2500, "2.5,1,abc,0"), 1700, "0.1,1,1,0"));
  bad.push_back(replace_line(good, 1500, "1,2"));
  bad.push_back(replace_line(good, 40, "0.0001,nan,1,0"));
  bad.push_back(replace_line(good, 3000, std::string(kMaxInputLineBytes + 1, '1')));
  for (std::size_t line = 1400; line < 1800; line += 37) {
    bad.push_back(replace_line(good, line, "0,0,0,0"));  // time back, also at a seam
  }
  for (const auto& text : bad) {
    const std::string expected = error_of(text, threads(1));
    ASSERT_NE(expected, "no error");
    for (unsigned n : {2u, 3u, 5u}) EXPECT_EQ(error_of(text, threads(n)), expected) << n;
  }
  EXPECT_EQ(error_of(bad[1], threads(1)),
            "5 in.csv:1700: time goes backwards: t = 0.1 after t = 1.659; expected "
            "non-decreasing time");
}

// ---------------------------------------------------------------- hostile input

namespace {

// A binary trace assembled by hand (docs/trace-format.md), to say what no writer would.
std::string ctb(const std::string& header, const std::vector<double>& values, std::uint64_t rows,
                const std::string& trailer) {
  std::string s = "CTRACEB1";
  const auto h = static_cast<std::uint32_t>(header.size());
  s.append(reinterpret_cast<const char*>(&h), 4);
  s += header;
  s.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(double));
  s += trailer;
  const auto tb = static_cast<std::uint32_t>(trailer.size());
  s.append(reinterpret_cast<const char*>(&rows), 8);
  s.append(reinterpret_cast<const char*>(&tb), 4);
  s += "CTBE";
  return s;
}

std::string read_error(const std::filesystem::path& dir, const std::string& bytes) {
  const std::string path = (dir / "x.ctb").string();
  { std::ofstream(path, std::ios::binary) << bytes; }
  try {
    read_trace(path);
  } catch (const Error& e) {
    const std::string what = e.what();
    return what.substr(what.find(": ") + 2);  // without the path
  }
  return "no error";
}

}  // namespace

TEST(BinaryTrace, RowCountIsCheckedWithoutOverflow) {
  const circtest::testing::ScratchDir scratch("circtest-core");
  const auto dir = scratch.dir();
  // 2 columns of 8 bytes: (2^59 + 1) * 16 wraps to 16, the bytes of exactly one row.
  const std::uint64_t rows = (std::uint64_t{1} << 59) + 1;
  EXPECT_EQ(read_error(dir, ctb("t,x\n", {0.0, 1.0}, rows, "")),
            "binary trace: 576460752303423489 rows of 2 columns do not fill the file");
  EXPECT_EQ(read_error(dir, ctb("t,x\n", {0.0, 1.0}, ~std::uint64_t{0}, "")),
            "binary trace: 18446744073709551615 rows of 2 columns do not fill the file");
  EXPECT_EQ(read_error(dir, ctb("t,x\n", {0.0, 1.0}, 1, "")), "no error");
  std::filesystem::remove_all(dir);
}

TEST(BinaryTrace, HeaderAndTrailerTextHoldNoRows) {
  const circtest::testing::ScratchDir scratch("circtest-core");
  const auto dir = scratch.dir();
  EXPECT_EQ(read_error(dir, ctb("# a: b\nt,x\n5,6\n", {0.0, 1.0}, 1, "")),
            "binary trace header text, line 3: expected only '# key: value' lines after the "
            "header row, got '5,6'");
  EXPECT_EQ(read_error(dir, ctb("t,x\n", {0.0, 1.0}, 1, "# rows: 1\n7,8\n")),
            "binary trace trailer text, line 2: expected only '# key: value' lines after the "
            "header row, got '7,8'");
  EXPECT_EQ(read_error(dir, ctb("\xEF\xBB\xBF# a: b\nt,x\n", {0.0, 1.0}, 1, "# rows: 1\n\n")),
            "no error");
  std::filesystem::remove_all(dir);
}

TEST(BinaryTrace, BulkAndRecordByRecordReadsAgree) {
  // Stretches on several threads must report the same first bad record as one thread.
  const circtest::testing::ScratchDir scratch("circtest-core");
  const auto dir = scratch.dir();
  std::vector<std::pair<double, double>> rows;
  for (int i = 0; i < 50000; ++i) rows.emplace_back(i * 1e-3, 1.0);
  rows[30000].second = INFINITY;
  rows[41000].first = 0.0;  // later: time back
  const std::string path = write_binary(dir, rows);
  for (unsigned n : {1u, 2u, 3u}) {
    TraceReadOptions o = threads(n);
    try {
      read_trace(path, o);
      FAIL();
    } catch (const ParseError& e) {
      EXPECT_EQ(std::string(e.what()),
                path + ": record 30001: column 'x': expected a finite number, got 'inf'");
    }
  }
  rows[30000].second = 1.0;
  const std::string p2 = write_binary(dir, rows);
  for (unsigned n : {1u, 2u, 3u}) {
    try {
      read_trace(p2, threads(n));
      FAIL();
    } catch (const DataError& e) {
      EXPECT_EQ(std::string(e.what()), p2 + ": record 41001: time goes backwards: t = 0 after t = "
                                            "40.999; expected non-decreasing time");
    }
  }
  rows[41000].first = 41.0;
  // Time back exactly where the rows are shared out (2 workers: row 25000; 3: 16666, 33332).
  for (const int seam : {16666, 25000, 33332}) {
    auto back = rows;
    back[static_cast<std::size_t>(seam)].first = 0.0;
    const std::string p3 = write_binary(dir, back);
    for (unsigned n : {1u, 2u, 3u}) {
      try {
        read_trace(p3, threads(n));
        FAIL() << seam << " " << n;
      } catch (const DataError& e) {
        EXPECT_EQ(std::string(e.what()),
                  fmt::format("{}: record {}: time goes backwards: t = 0 after t = {}; expected "
                              "non-decreasing time",
                              p3, seam + 1, (seam - 1) * 1e-3));
      }
    }
  }
  const Trace t = read_trace(write_binary(dir, rows), threads(3));
  ASSERT_EQ(t.rows(), 50000u);
  EXPECT_EQ((*t.column("t"))[49999], 49999 * 1e-3);
  EXPECT_EQ(t.line_of_row[49999], 50000u);
  std::filesystem::remove_all(dir);
}
