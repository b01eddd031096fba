#pragma once
// Opening an input file the same way everywhere: a named input is read only when it is a
// regular file; anything else (a FIFO, whose open and read wait for a writer; a device such as
// /dev/zero; a directory; a socket) is refused with an IoError "FILE: is a FIFO, not a regular
// file" (exit code io) before it is opened. Standard input ("-", or /dev/stdin) is read
// whatever it is (a pipe from another program). Every reader of core (traces, INI files, JSON
// documents, digests) opens its input here.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace circtest {

// The longest line any circtest text reader accepts (a trace row, an INI line).
inline constexpr std::size_t kMaxInputLineBytes = std::size_t{1} << 20;

// "a directory", "a character device", "a FIFO", "a symbolic link", ...: what a file of this
// st_mode is, for the refusals of every reader and writer ("X: is a FIFO, expected ...").
const char* file_kind_name(unsigned int st_mode) noexcept;

class InputFile {
 public:
  // "-" is standard input, as is a path naming the file standard input is (/dev/stdin); any
  // other path must be a regular file. Throws IoError (exit code io) naming the path.
  explicit InputFile(const std::string& path);
  ~InputFile();
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  int fd() const { return fd_; }
  const std::string& path() const { return path_; }
  // A regular file (size known, can be mapped and read at offsets); else a stream.
  bool regular() const { return regular_; }
  std::uint64_t size() const { return size_; }  // 0 for a stream

 private:
  std::string path_;
  int fd_ = -1;
  bool owned_ = false;
  bool regular_ = false;
  std::uint64_t size_ = 0;
};

// The most any input read whole may hold (a diagnosis or result JSON, an INI and its includes,
// a comp table, a polar export, a manifest): far above any real one, low enough that a wrong
// file (a disk image, a log) is refused instead of filling memory. Traces are streamed and
// have limits of their own (docs/input-checks.md).
inline constexpr std::size_t kMaxWholeInputBytes = std::size_t{64} << 20;

// The whole file, refusing what InputFile refuses; IoError naming the limit when it holds
// more than max_bytes (checked before reading a regular file, while reading a pipe).
std::string read_input_bytes(const std::string& path, std::size_t max_bytes = kMaxWholeInputBytes);

// As read_input_bytes, and also refusing with ParseError (naming the line) a line longer than
// kMaxInputLineBytes.
std::string read_input_text(const std::string& path, std::size_t max_bytes = kMaxWholeInputBytes);

// Calls consume(block) for every block of the file in order (no size limit: for digests of
// files of any length), refusing what InputFile refuses.
void for_each_input_block(const std::string& path,
                          const std::function<void(std::string_view block)>& consume);

}  // namespace circtest
