// The manifest reader of circcomp revert (compensation/manifest): any bytes parse or give a
// documented error (ParseError, or UnsafePathError for a name that is not a plain name inside
// the configuration). What parses names only plain relative files and NAME.orig originals,
// and, for version 2, what circcomp writes back from it reads back as the same manifest.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "circtest/compensation/manifest.hpp"
#include "fuzz_main_common.hpp"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

bool plain(const std::string& name) {
  if (name.empty() || name.front() == '/' || name.back() == '/') return false;
  std::size_t begin = 0;
  while (begin <= name.size()) {
    std::size_t end = name.find('/', begin);
    if (end == std::string::npos) end = name.size();
    const std::string part = name.substr(begin, end - begin);
    if (part.empty() || part == "." || part == "..") return false;
    begin = end + 1;
  }
  for (const char c : name) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return false;
  }
  return true;
}

void check_entries(const std::vector<circtest::compensation::ManifestEntry>& entries) {
  for (const auto& e : entries) {
    check(plain(e.name));
    if (e.existed) {
      check(plain(e.original) && e.original.find('/') == std::string::npos &&
            e.original.ends_with(".orig"));
    } else {
      check(e.original.empty());
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace circtest::compensation;
  static const ConfigDir dir("/tmp/fuzz.ini");  // version-1 paths are checked against /tmp
  const std::string text(reinterpret_cast<const char*>(data), size);
  circtest::fuzz::expect_documented_outcome([&] {
    const Manifest m = parse_manifest(text, "fuzz-manifest", dir);
    check_entries(m.last);
    check_entries(m.found);
    check(m.last.size() + m.found.size() <= 2 * kMaxManifestEntries);
    if (m.version == 2) {
      const Manifest back = parse_manifest(render_manifest(m), "fuzz-manifest-back", dir);
      check(render_manifest(back) == render_manifest(m));
    }
  });
  return 0;
}
