// Reading and writing JSON documents: every refusal a ParseError with the file and line (never
// the JSON library's exception), text that is not UTF-8 written with U+FFFD, and the UTF-8
// and XML text helpers underneath.
#include "circtest/core/json_text.hpp"

#include <gtest/gtest.h>

#include <string>

#include "circtest/core/strings.hpp"
#include "expect_error.hpp"
#include "scratch.hpp"

using namespace circtest;

TEST(JsonText, ParsesADocument) {
  const auto j = parse_json_text("{\"a\": [1, 2.5, \"x\"]}", "d.json");
  EXPECT_EQ(j["a"][1], 2.5);
  const auto o = parse_ordered_json_text("{\"b\": 1, \"a\": 2}", "d.json");
  EXPECT_EQ(o.begin().key(), "b");
}

TEST(JsonText, RefusalsNameTheFileAndLine) {
  EXPECT_ERROR(parse_json_text("{\n\"a\": 1e400}", "d.json"), ExitCode::parse,
               "d.json:2: not valid JSON (column 10): number overflow parsing '1e400'");
  EXPECT_ERROR(parse_json_text("{\"a\":\n\n tru}", "d.json"), ExitCode::parse,
               "d.json:3: not valid JSON");
  EXPECT_ERROR(parse_json_text("{\"a\": \"J\xFCrgen\"}", "d.json"), ExitCode::parse,
               "d.json:1: not valid JSON");
  EXPECT_ERROR(parse_json_text("", "d.json"), ExitCode::parse, "d.json:1: not valid JSON");
  EXPECT_ERROR(parse_json_text("{} {}", "d.json"), ExitCode::parse, "d.json:1: not valid JSON");
}

TEST(JsonText, NestingIsBoundedWhateverTheBrackets) {
  const std::string ok = std::string(kMaxJsonDepth, '[') + std::string(kMaxJsonDepth, ']');
  EXPECT_NO_THROW(parse_json_text(ok, "d.json"));
  const std::string deep = "{\"a\":\n" + std::string(100000, '[') + std::string(100000, ']') + "}";
  EXPECT_ERROR(parse_json_text(deep, "d.json"), ExitCode::parse,
               "d.json:2: arrays and objects nested deeper than 64 levels");
  // Brackets inside strings are text.
  const std::string in_string = "[\"" + std::string(1000, '[') + "\\\"" + "\"]";
  EXPECT_NO_THROW(parse_json_text(in_string, "d.json"));
}

TEST(JsonText, FilesHaveASizeLimit) {
  circtest::testing::ScratchDir dir;
  circtest::testing::spit(dir.file("d.json"), "{\"a\": [1, 2, 3]}");
  EXPECT_EQ(read_json_file(dir.file("d.json"))["a"].size(), 3u);
  EXPECT_ERROR(read_json_file(dir.file("d.json"), 10), ExitCode::io,
               dir.file("d.json") + ": larger than the limit of 10 bytes");
  EXPECT_ERROR(read_json_file("/dev/zero"), ExitCode::io, "/dev/zero: is a character device");
}

TEST(JsonText, WritingReplacesBytesThatAreNotUtf8) {
  nlohmann::json j = {{"source", "caf\xE9.csv"}};
  EXPECT_EQ(json_text(j), "{\"source\":\"caf\xEF\xBF\xBD.csv\"}");
  nlohmann::ordered_json o = {{"b", "ok \xC3\xA9"}};
  EXPECT_EQ(json_text(o, 1), "{\n \"b\": \"ok \xC3\xA9\"\n}");
}

TEST(JsonText, ReaderNamesTheKeyPath) {
  const auto j = parse_json_text("{\"r\": {\"x\": \"big\", \"y\": 1e300, \"n\": -1}}", "d.json");
  const JsonReader<nlohmann::json> rd("d.json", "test JSON", 1e9);
  EXPECT_ERROR(rd.number(rd.at(j, "r", ""), "x", "r"), ExitCode::parse,
               "d.json: test JSON 'r.x': expected a number");
  EXPECT_ERROR(rd.number(rd.at(j, "r", ""), "y", "r"), ExitCode::data,
               "d.json: test JSON 'r.y': 1e+300 is not a usable number (at most 1e+09 in size)");
  EXPECT_ERROR(rd.count(rd.at(j, "r", ""), "n", "r"), ExitCode::parse,
               "'r.n': expected a non-negative integer");
  EXPECT_ERROR(rd.at(j, "missing", ""), ExitCode::parse, "'missing': expected a value (missing)");
}

TEST(Utf8, InvalidBytesAreFoundAndReplaced) {
  EXPECT_EQ(invalid_utf8_offset("plain"), std::string_view::npos);
  EXPECT_EQ(invalid_utf8_offset("J\xC3\xBCrgen \xE2\x82\xAC \xF0\x9F\x98\x80"),
            std::string_view::npos);
  EXPECT_EQ(invalid_utf8_offset("J\xFCrgen"), 1u);         // Latin-1
  EXPECT_EQ(invalid_utf8_offset("ab\xC0\xAF"), 2u);        // overlong '/'
  EXPECT_EQ(invalid_utf8_offset("\xED\xA0\x80"), 0u);      // a surrogate
  EXPECT_EQ(invalid_utf8_offset("\xF4\x90\x80\x80"), 0u);  // above U+10FFFF
  EXPECT_EQ(invalid_utf8_offset("ok\xE2\x82"), 2u);        // cut short
  EXPECT_EQ(utf8_replacing_invalid("caf\xE9!"), "caf\xEF\xBF\xBD!");
  EXPECT_EQ(utf8_replacing_invalid("\xC3\xA9"), "\xC3\xA9");
}

TEST(Utf8, XmlEscapeLeavesOnlyWellFormedXmlText) {
  EXPECT_EQ(xml_escape("a<b & \"c\">"), "a&lt;b &amp; &quot;c&quot;&gt;");
  EXPECT_EQ(xml_escape("caf\xE9"), "caf\xEF\xBF\xBD");
  EXPECT_EQ(xml_escape(std::string("a\x01"
                                   "b\tc",
                                   5)),
            "a\xEF\xBF\xBD"
            "b\tc");
  EXPECT_EQ(xml_escape("\xC3\xA9t\xC3\xA9"), "\xC3\xA9t\xC3\xA9");
}
