#pragma once
// <configuration>/.circcomp/manifest: what `circcomp apply` changed, so that `circcomp revert`
// can undo it. Version 2, one tab-separated record a line after "circcomp-manifest 2":
//   LAYER  KIND  NAME  ORIGINAL  SHA256
// LAYER "last" (the latest apply: `revert` undoes it) or "found" (every file any apply since
// the first has changed, with its state before the first one: `revert --to as-found`); KIND
// "existed" (ORIGINAL is the file in .circcomp/ holding its content then) or "created" (it did
// not exist; ORIGINAL is "-"); NAME relative to the configuration directory; SHA256 of what
// circcomp last wrote to NAME, which revert checks before it overwrites or removes anything.
// Version 1 (KIND, ORIGINAL, absolute PATH; no checksums) is still read when every path lies
// inside the configuration directory.
#include <cstddef>
#include <string>
#include <vector>

#include "circtest/compensation/config_dir.hpp"

namespace circtest::compensation {

inline constexpr std::size_t kMaxManifestEntries = 4096;

struct ManifestEntry {
  std::string name;      // relative to the configuration directory
  bool existed = false;  // false: created by circcomp, revert removes it
  std::string original;  // file name in .circcomp/ (*.orig) when existed
  std::string sha256;    // what circcomp last wrote to NAME; empty in a version-1 manifest
};

struct Manifest {
  int version = 2;
  std::vector<ManifestEntry> last;   // undone by `circcomp revert`
  std::vector<ManifestEntry> found;  // the state before the first apply
};

// Throws ParseError (SOURCE and line) for anything render_manifest does not write, and
// UnsafePathError for a name that is not a plain name inside DIR (absolute, "..", a version-1
// path outside) or an original that is not a plain "*.orig" name.
Manifest parse_manifest(const std::string& text, const std::string& source, const ConfigDir& dir);
std::string render_manifest(const Manifest& manifest);

}  // namespace circtest::compensation
