#include "circtest/compensation/manifest.hpp"

#include <fmt/format.h>

#include <set>
#include <string_view>

#include "circtest/core/error.hpp"

namespace circtest::compensation {

namespace {

std::vector<std::string> split_tabs(std::string_view line) {
  std::vector<std::string> fields;
  std::size_t begin = 0;
  for (;;) {
    const std::size_t tab = line.find('\t', begin);
    fields.emplace_back(line.substr(begin, tab == std::string_view::npos ? tab : tab - begin));
    if (tab == std::string_view::npos) return fields;
    begin = tab + 1;
  }
}

bool is_sha256(std::string_view s) {
  if (s.size() != 64) return false;
  for (const char c : s) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

struct LineReader {
  const std::string& source;
  const ConfigDir& dir;
  std::size_t line = 0;

  [[noreturn]] void fail(const std::string& what) const { throw ParseError(source, line, what); }
  std::string where() const { return fmt::format("{}:{}", source, line); }

  void check_original(const std::string& original) const {
    ConfigDir::check_name(original, where());
    if (original.find('/') != std::string::npos || !original.ends_with(".orig")) {
      throw UnsafePathError(where(), fmt::format("original '{}': expected a NAME.orig file of "
                                                 "circcomp's own directory",
                                                 original));
    }
  }
  ManifestEntry entry(const std::string& kind, const std::string& name,
                      const std::string& original) const {
    if (kind != "existed" && kind != "created") {
      fail("unknown kind '" + kind + "' (expected existed or created)");
    }
    ConfigDir::check_name(name, where());
    ManifestEntry e{name, kind == "existed", "", ""};
    if (e.existed) {
      check_original(original);
      e.original = original;
    } else if (original != "-") {
      fail("a created file has no original: expected '-', got '" + original + "'");
    }
    return e;
  }
  // Version 1: KIND ORIGINAL ABSOLUTE-PATH, read only when the path lies inside DIR.
  ManifestEntry version1(const std::vector<std::string>& f) const {
    if (f.size() != 3) fail("expected KIND<TAB>ORIGINAL<TAB>PATH (version 1)");
    const auto name = dir.name_of(f[2]);
    if (!f[2].starts_with('/') || !name) {
      throw UnsafePathError(where(), fmt::format("'{}' is not a path inside the configuration "
                                                 "directory {}: circcomp touches nothing outside",
                                                 f[2], dir.root()));
    }
    return entry(f[0], *name, f[1]);
  }
  ManifestEntry version2(const std::vector<std::string>& f, bool& last) const {
    if (f.size() != 5) fail("expected LAYER<TAB>KIND<TAB>NAME<TAB>ORIGINAL<TAB>SHA256");
    if (f[0] != "last" && f[0] != "found") fail("unknown layer '" + f[0] + "' (last or found)");
    last = f[0] == "last";
    ManifestEntry e = entry(f[1], f[2], f[3]);
    if (!is_sha256(f[4])) fail("expected the SHA-256 (64 hex digits) of what circcomp wrote");
    e.sha256 = f[4];
    return e;
  }
};

}  // namespace

Manifest parse_manifest(const std::string& text, const std::string& source, const ConfigDir& dir) {
  Manifest m;
  LineReader r{source, dir};
  std::set<std::string> names[2];
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    const std::string_view line(text.data() + begin, end - begin);
    begin = end + 1;
    ++r.line;
    if (r.line == 1) {
      if (line == "circcomp-manifest 1") {
        m.version = 1;
      } else if (line != "circcomp-manifest 2") {
        r.fail(line.starts_with("circcomp-manifest ")
                   ? "a manifest version this circcomp does not know (1 and 2): a newer circcomp "
                     "wrote it; revert with that one"
                   : "not a circcomp manifest");
      }
      continue;
    }
    bool last = true;
    const auto fields = split_tabs(line);
    const ManifestEntry e = m.version == 1 ? r.version1(fields) : r.version2(fields, last);
    if (!names[last ? 0 : 1].insert(e.name).second) r.fail("'" + e.name + "' is named twice");
    if (m.last.size() + m.found.size() >= kMaxManifestEntries) {
      r.fail(fmt::format("more than {} files: not a manifest circcomp wrote", kMaxManifestEntries));
    }
    (last ? m.last : m.found).push_back(e);
  }
  if (r.line == 0) r.fail("empty: not a circcomp manifest");
  // A version-1 manifest is one apply: its originals are also the state as found.
  if (m.version == 1) m.found = m.last;
  return m;
}

std::string render_manifest(const Manifest& manifest) {
  std::string out = "circcomp-manifest 2\n";
  auto layer = [&out](const char* name, const std::vector<ManifestEntry>& entries) {
    for (const ManifestEntry& e : entries) {
      out += fmt::format("{}\t{}\t{}\t{}\t{}\n", name, e.existed ? "existed" : "created", e.name,
                         e.existed ? e.original : "-", e.sha256);
    }
  };
  layer("last", manifest.last);
  layer("found", manifest.found);
  return out;
}

}  // namespace circtest::compensation
