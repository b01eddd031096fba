// circana's documents, history and option values against hostile input: JSON that the library
// would throw on (a number beyond a double, wrong types, deep nesting, bytes that are not
// UTF-8), dates that do not exist, values outside any plausible range and inputs too large to
// read whole. Each case: the exit code and the words of the refusal, nothing stored.
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include "hostile_example.hpp"
#include "scratch.hpp"

namespace {

using namespace circtest::testing;  // ScratchDir, slurp, spit, run_command, kExample

bool has(const std::string& text, const std::string& words) {
  return text.find(words) != std::string::npos;
}

// The run's exit code and that its message holds every one of `words`.
void expect_refusal(const CommandResult& r, int code, const std::vector<std::string>& words) {
  EXPECT_EQ(r.exit_code, code) << r.err;
  for (const auto& w : words) EXPECT_TRUE(has(r.err, w)) << "missing '" << w << "' in: " << r.err;
  EXPECT_FALSE(has(r.err, "internal error")) << r.err;
}

// The example trace with `lines` inserted at the top (metadata).
std::string trace_with(const ScratchDir& dir, const std::string& name, const std::string& lines) {
  const std::string path = dir.file(name);
  spit(path, lines + slurp(kExample));
  return path;
}

// analyze --json of the example, for documents given to circana store.
std::string result_document() {
  const CommandResult r = run_command({CIRCANA_PATH, "analyze", kExample, "--json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return r.out;
}

// The document with the first match of `pattern` replaced.
std::string edited(const std::string& document, const std::string& pattern,
                   const std::string& replacement) {
  const std::string out = std::regex_replace(document, std::regex(pattern), replacement,
                                             std::regex_constants::format_first_only);
  EXPECT_NE(out, document) << pattern;
  return out;
}

std::string db_of(const ScratchDir& dir) {
  return "sqlite:" + dir.file("history.sqlite");
}

TEST(HostileHistory, ANumberBeyondADoubleInAResultIsAParseErrorWithItsLine) {
  ScratchDir dir;
  const std::string doc = dir.file("result.json");
  spit(doc, edited(result_document(), R"("H": [-0-9.e]+)", R"("H": 1e400)"));
  const CommandResult r =
      run_command({CIRCANA_PATH, "store", doc, "--machine", "m", "--db", db_of(dir)});
  expect_refusal(r, 4, {doc + ":", "1e400", "not valid JSON"});
  EXPECT_FALSE(std::filesystem::exists(dir.file("history.sqlite")));
}

TEST(HostileHistory, AHugeNumberInAResultIsRefusedNamingItsKey) {
  ScratchDir dir;
  const std::string doc = dir.file("result.json");
  spit(doc, edited(result_document(), R"(("pairs": \[\s*\{[^}]*?"H": )[-0-9.e]+)", "$011.7e308"));
  const CommandResult r =
      run_command({CIRCANA_PATH, "store", doc, "--machine", "m", "--db", db_of(dir)});
  expect_refusal(r, 5, {doc, "pairs[0].H", "1.7e+308"});
  const CommandResult h =
      run_command({CIRCANA_PATH, "history", "--machine", "m", "--db", db_of(dir)});
  EXPECT_FALSE(has(h.out, "inf")) << h.out;
}

TEST(HostileHistory, AWrongTypeOrAMissingKeyInAResultNamesTheKey) {
  ScratchDir dir;
  const std::string doc = dir.file("result.json");
  spit(doc, edited(result_document(), R"("G": [-0-9.e]+)", R"("G": "large")"));
  expect_refusal(run_command({CIRCANA_PATH, "store", doc, "--machine", "m", "--db", db_of(dir)}), 4,
                 {doc, "runs[0].G", "a number"});
  spit(doc, edited(result_document(), R"("radius_factor")", R"("radius_fact")"));
  expect_refusal(run_command({CIRCANA_PATH, "store", doc, "--machine", "m", "--db", db_of(dir)}), 4,
                 {doc, "temperature.radius_factor", "missing"});
}

TEST(HostileHistory, DeepNestingInADocumentIsRefusedWithItsLine) {
  ScratchDir dir;
  const std::string doc = dir.file("result.json");
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  spit(doc,
       edited(result_document(), R"("notes": \[)", "\"extra\": " + deep + ",\n  \"notes\": ["));
  expect_refusal(run_command({CIRCANA_PATH, "store", doc, "--machine", "m", "--db", db_of(dir)}), 4,
                 {doc + ":", "nested deeper than 64"});
  spit(dir.file("diag.json"), "{\"schema\": \"circtest.diagnosis/1\",\n\"x\": " + deep + "}");
  expect_refusal(run_command({CIRCANA_PATH, "report", kExample, "-o", dir.file("r.html"),
                              "--diagnosis", dir.file("diag.json")}),
                 4, {dir.file("diag.json") + ":", "nested deeper than 16 levels"});
  EXPECT_FALSE(std::filesystem::exists(dir.file("r.html")));
}

TEST(HostileHistory, ADiagnosisDocumentOfTheWrongShapeNamesTheKey) {
  ScratchDir dir;
  const CommandResult d = run_command({CIRCANA_PATH, "diagnose", kExample, "--json"});
  ASSERT_EQ(d.exit_code, 0) << d.err;
  const std::string diag = dir.file("diag.json");
  auto report = [&] {
    return run_command(
        {CIRCANA_PATH, "report", kExample, "-o", dir.file("r.html"), "--diagnosis", diag});
  };
  spit(diag, edited(d.out, R"("percent": [-0-9.e]+)", R"("percent": "most")"));
  expect_refusal(report(), 4, {diag, "contributions[0].percent", "a number"});
  spit(diag, edited(d.out, R"("model_G_mm")", R"("model_G")"));
  expect_refusal(report(), 4, {diag, "model_G_mm", "missing"});
  spit(diag, edited(d.out, R"("model_G_mm": [-0-9.e]+)", R"("model_G_mm": -1e400)"));
  expect_refusal(report(), 4, {diag + ":", "-1e400"});
  spit(diag, edited(d.out, R"("model_G_mm": [-0-9.e]+)", R"("model_G_mm": 1e300)"));
  expect_refusal(report(), 5, {diag, "model_G_mm", "1e+300"});
  EXPECT_FALSE(std::filesystem::exists(dir.file("r.html")));
}

TEST(HostileHistory, MetadataThatIsNotUtf8IsRefusedWithItsLineAndKey) {
  ScratchDir dir;
  const std::string trace = trace_with(dir, "latin1.csv", "# operator: J\xFCrgen\n");
  for (const std::vector<std::string>& extra :
       {std::vector<std::string>{"--json"}, {}, {"--store", "--db", db_of(dir)}}) {
    std::vector<std::string> argv = {CIRCANA_PATH, "analyze", trace, "--machine", "m"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    expect_refusal(run_command(argv), 4, {trace + ":1:", "'operator'", "not UTF-8", "0xFC"});
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("history.sqlite")));
}

TEST(HostileHistory, AnOptionValueThatIsNotUtf8IsAUsageError) {
  expect_refusal(
      run_command({CIRCANA_PATH, "analyze", kExample, "--json", "--operator", "J\xFCrgen"}), 2,
      {"--operator", "not UTF-8", "0xFC"});
  expect_refusal(run_command({CIRCANA_PATH, "history", "--machine", "M\xE4hwerk"}), 2,
                 {"--machine", "not UTF-8"});
}

TEST(HostileHistory, AFileNameThatIsNotUtf8IsReplacedInJson) {
  ScratchDir dir;
  const std::string trace = trace_with(dir, "caf\xE9.csv", "");
  const CommandResult r = run_command({CIRCANA_PATH, "analyze", trace, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(has(r.out, "caf\xEF\xBF\xBD.csv")) << r.out.substr(0, 300);
  const CommandResult s = run_command(
      {CIRCANA_PATH, "analyze", trace, "--machine", "m", "--store", "--db", db_of(dir)});
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const CommandResult h =
      run_command({CIRCANA_PATH, "history", "--machine", "m", "--json", "--db", db_of(dir)});
  ASSERT_EQ(h.exit_code, 0) << h.err;
  EXPECT_TRUE(has(h.out, "caf\xEF\xBF\xBD.csv")) << h.out;
}

TEST(HostileHistory, ADateThatDoesNotParseIsNotStored) {
  ScratchDir dir;
  for (const std::string& date :
       std::vector<std::string>{"yesterday", "2026-02-30", "2026-13-01", "2025-02-29T10:00:00Z",
                                "2026-11-23T24:00:00Z", "2026-11-23 junk"}) {
    SCOPED_TRACE(date);
    const std::string trace = trace_with(dir, "dated.csv", "# date: " + date + "\n");
    expect_refusal(run_command({CIRCANA_PATH, "analyze", trace, "--machine", "m", "--store", "--db",
                                db_of(dir)}),
                   5, {trace + ":1:", "'date'", "ISO 8601"});
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("history.sqlite")));
  // A valid date with an offset is stored in UTC; a leap day exists in a leap year.
  for (const std::string& date :
       {std::string("2026-11-23T15:47:14+01:00"), std::string("2024-02-29")}) {
    const std::string trace = trace_with(dir, "dated.csv", "# start_time: " + date + "\n");
    const CommandResult r = run_command(
        {CIRCANA_PATH, "analyze", trace, "--machine", "m", "--store", "--db", db_of(dir)});
    EXPECT_EQ(r.exit_code, 0) << r.err;
  }
  const CommandResult h =
      run_command({CIRCANA_PATH, "history", "--machine", "m", "--db", db_of(dir)});
  ASSERT_EQ(h.exit_code, 0) << h.err;
  EXPECT_TRUE(has(h.out, "2026-11-23T14:47:14Z")) << h.out;
  EXPECT_TRUE(has(h.out, "2024-02-29")) << h.out;
}

TEST(HostileHistory, SinceMustBeARealDate) {
  ScratchDir dir;
  for (const std::string& since :
       std::vector<std::string>{"2026-13-45", "2026-00-10", "2026-04-31", "2025-02-29",
                                "2026-11-23T25:00", "2026-11-23T10:61", "2026-1-5"}) {
    SCOPED_TRACE(since);
    expect_refusal(run_command({CIRCANA_PATH, "history", "--machine", "m", "--since", since, "--db",
                                db_of(dir)}),
                   2, {"--since", "'" + since + "'"});
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("history.sqlite")));
}

TEST(HostileHistory, NumericOptionsOutsideTheirPlausibleRangeAreUsageErrors) {
  ScratchDir dir;
  const std::vector<std::vector<std::string>> cases = {{"--t-machine", "-274"},
                                                       {"--t-instrument", "1e6"},
                                                       {"--alpha-machine", "1"},
                                                       {"--alpha-instrument", "-0.5"},
                                                       {"--radius", "1e308"},
                                                       {"--centre", "1e300,0"},
                                                       {"--scale-um-per-div", "1e-300"},
                                                       {"--scale-um-per-div", "1e300"},
                                                       {"--radius-tolerance", "1e300"}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c[0] + " " + c[1]);
    expect_refusal(
        run_command({CIRCANA_PATH, "analyze", kExample, c[0], c[1], "--svg", dir.file("p.svg")}), 2,
        {c[0] + ":", "expected", "'" + c[1] + "'"});
  }
  expect_refusal(run_command({CIRCANA_PATH, "diagnose", kExample, "--pitch", "X=1e-200"}), 2,
                 {"--pitch", "X=1e-200"});
  expect_refusal(run_command({CIRCANA_PATH, "history", "--machine", "m", "--limits", "H=1e308",
                              "--db", db_of(dir)}),
                 2, {"--limits H", "1e308"});
  EXPECT_FALSE(std::filesystem::exists(dir.file("p.svg")));
}

TEST(HostileHistory, ImportPolarRefusesSizesThatMakeNoTest) {
  ScratchDir dir;
  spit(dir.file("polar.txt"), "0 1.5\n90 2.0\n180 -1.0\n270 0.5\n");
  expect_refusal(run_command({CIRCANA_PATH, "import-polar", dir.file("polar.txt"), "--radius",
                              "1e308", "-o", dir.file("t.csv")}),
                 2, {"--radius", "'1e308'"});
  // Numbers of the export that would size the trace's numbers rather than describe a test.
  for (const std::string& row : {std::string("90 1e300"), std::string("1e300 1")}) {
    spit(dir.file("polar.txt"), "0 1.5\n" + row + "\n180 -1.0\n270 0.5\n");
    expect_refusal(run_command({CIRCANA_PATH, "import-polar", dir.file("polar.txt"), "--radius",
                                "50", "-o", dir.file("t.csv")}),
                   4, {dir.file("polar.txt") + ":2:", "within +-3600 deg", "+-10000 um", row});
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("t.csv")));
}

TEST(HostileHistory, UnknownOptionsAndCommandsGetADidYouMean) {
  expect_refusal(run_command({CIRCANA_PATH, "analyze", kExample, "--radus", "75"}), 2,
                 {"unknown option --radus; did you mean --radius?"});
  expect_refusal(run_command({CIRCANA_PATH, "history", "--machne", "m"}), 2,
                 {"unknown option --machne; did you mean --machine?"});
  expect_refusal(run_command({CIRCANA_PATH, "analyse", kExample}), 2,
                 {"unknown command 'analyse'", "did you mean analyze?"});
  // Nothing close: no guess.
  const CommandResult r = run_command({CIRCANA_PATH, "analyze", kExample, "--zzzzzzzz"});
  expect_refusal(r, 2, {"unknown option --zzzzzzzz"});
  EXPECT_FALSE(has(r.err, "did you mean")) << r.err;
}

TEST(HostileHistory, DocumentsOverTheSizeLimitAreRefusedUnread) {
  ScratchDir dir;
  // Sparse files: the size is refused from the file's length, before a byte is read.
  const std::string big_json = dir.file("big.json");
  spit(big_json, "{");
  std::filesystem::resize_file(big_json, (std::uintmax_t{16} << 20) + 1);
  expect_refusal(run_command({CIRCANA_PATH, "store", big_json, "--db", db_of(dir)}), 3,
                 {big_json, "larger than the limit of 16 MiB"});
  expect_refusal(run_command({CIRCANA_PATH, "report", kExample, "-o", dir.file("r.html"),
                              "--diagnosis", big_json}),
                 3, {big_json, "larger than the limit of 4 MiB"});
  const std::string big_polar = dir.file("big.txt");
  spit(big_polar, "0 1\n");
  std::filesystem::resize_file(big_polar, (std::uintmax_t{64} << 20) + 1);
  expect_refusal(run_command({CIRCANA_PATH, "import-polar", big_polar, "--radius", "50", "-o",
                              dir.file("t.csv")}),
                 3, {big_polar, "larger than the limit of 64 MiB"});
  // A device is never read.
  expect_refusal(run_command({CIRCANA_PATH, "report", kExample, "-o", dir.file("r.html"),
                              "--diagnosis", "/dev/zero"}),
                 3, {"/dev/zero", "character device"});
  expect_refusal(run_command({CIRCANA_PATH, "store", "/dev/zero", "--db", db_of(dir)}), 3,
                 {"/dev/zero", "character device"});
  EXPECT_FALSE(std::filesystem::exists(dir.file("history.sqlite")));
}

}  // namespace
