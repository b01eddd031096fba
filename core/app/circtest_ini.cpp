// circtest-ini: the shell scripts' INI reader and editor, on core's lossless IniDocument
// (LinuxCNC 2.9 reading rules, #INCLUDE followed, every other byte kept on an edit).
//   circtest-ini get FILE SECTION KEY        prints the value LinuxCNC reads; exit 5 if none
//   circtest-ini get-all FILE SECTION KEY    prints every occurrence, one a line
//   circtest-ini set FILE SECTION KEY VALUE  replaces (or adds) the key, atomically
//   circtest-ini replace FILE SECTION KEY VALUE  the same, but exit 5 when the key is absent
#include <iostream>
#include <string>
#include <string_view>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/cli.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/core/version.hpp"

using namespace circtest;

namespace {

constexpr const char* kUsage =
    "usage: circtest-ini get|get-all FILE SECTION KEY\n"
    "       circtest-ini set|replace FILE SECTION KEY VALUE\n";

void save(const IniDocument& doc) {
  for (std::size_t i = 0; i < doc.file_count(); ++i) {
    if (doc.file_modified(i)) write_file_atomic(doc.file_path(i), doc.render_file(i));
  }
}

int run(int argc, char** argv) {
  if (argc >= 2 && (std::string_view(argv[1]) == "--help" || std::string_view(argv[1]) == "-h")) {
    std::cout << kUsage;
    return 0;
  }
  if (argc >= 2 && std::string_view(argv[1]) == "--version") {
    std::cout << version_line("circtest-ini") << '\n';
    return 0;
  }
  if (argc < 5) throw UsageError(std::string("expected a command and its arguments\n") + kUsage);
  const std::string command = argv[1], file = argv[2], section = argv[3], key = argv[4];
  const bool reads = command == "get" || command == "get-all";
  const bool writes = command == "set" || command == "replace";
  if (!reads && !writes) throw UsageError("unknown command '" + command + "'\n" + kUsage);
  if (argc != (reads ? 5 : 6))
    throw UsageError(std::string("wrong number of arguments\n") + kUsage);
  if (writes) {
    if (const auto problem = ini_edit_problem(section, key, argv[5])) {
      throw UsageError(command + ": " + *problem + "\n" + kUsage);
    }
  }
  IniDocument doc = IniDocument::load(file);
  if (command == "get") {
    const auto value = doc.get(section, key);
    if (!value) throw DataError(file, 0, "no " + key + " in [" + section + "]");
    std::cout << *value << "\n";
  } else if (command == "get-all") {
    for (const auto& e : doc.get_all(section, key)) std::cout << e.value << "\n";
  } else {
    if (command == "replace" && !doc.find(section, key)) {
      throw DataError(file, 0, "no " + key + " in [" + section + "] to replace");
    }
    doc.set(section, key, argv[5]);
    save(doc);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return run_cli("circtest-ini", [&] { return run(argc, argv); });
}
