// circgen's command line: the input is split at NUL bytes into arguments and run through
// circgen's own main(), compiled in with -Dmain=circgen_main. Anything but exit 0 (program
// written to stdout, discarded) or a documented error code is a finding, and so is a
// program with a word that is not a finite, short number. Arguments that would read or
// write files (-o, --output, --ini) are dropped: the harness must not touch the disk.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

int circgen_main(int argc, char** argv);

namespace {
bool touches_files(const std::string& arg) {
  return arg.rfind("-o", 0) == 0 || arg.rfind("--o", 0) == 0 || arg.rfind("--i", 0) == 0 ||
         arg.rfind("--help", 0) == 0;
}
}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // stdout gets the programs; libFuzzer's -close_fd_mask=2 silences circgen's error lines.
  if (!std::freopen("/dev/null", "w", stdout)) std::abort();
  ::setenv("SOURCE_DATE_EPOCH", "0", 1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::string> args{"circgen"};
  std::string cur;
  for (std::size_t i = 0; i < size; ++i) {
    if (data[i] == 0) {
      args.push_back(cur);
      cur.clear();
    } else {
      cur += static_cast<char>(data[i]);
    }
  }
  if (!cur.empty()) args.push_back(cur);
  std::vector<std::string> kept;
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (i > 0 && touches_files(args[i])) {
      ++i;  // and its value
      continue;
    }
    kept.push_back(args[i]);
  }
  if (kept.size() > 64) return 0;
  std::vector<char*> argv;
  for (auto& a : kept) argv.push_back(a.data());
  argv.push_back(nullptr);
  const int code = circgen_main(static_cast<int>(kept.size()), argv.data());
  // README exit codes circgen may give: ok, usage, io, parse, limit. 1 is "a bug".
  if (code != 0 && code != 2 && code != 3 && code != 4 && code != 6) std::abort();
  return 0;
}
