#pragma once
// Opening an input file the same way everywhere: a regular file or a pipe is read, anything
// that would never end or is not data (a device such as /dev/zero, a directory, a socket) is
// refused with an IoError before a byte is read. Trace and INI readers both use it.
#include <cstddef>
#include <cstdint>
#include <string>

namespace circtest {

// The longest line any circtest text reader accepts (a trace row, an INI line).
inline constexpr std::size_t kMaxInputLineBytes = std::size_t{1} << 20;

class InputFile {
 public:
  // "-" is standard input. A character device is accepted only when it is standard input
  // (a terminal); a FIFO always is. Throws IoError (exit code io) naming the path.
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

// The whole file as text, refusing what InputFile refuses and, with ParseError (naming the
// line), a line longer than kMaxInputLineBytes; IoError when the file is over max_bytes.
std::string read_input_text(const std::string& path, std::size_t max_bytes = std::size_t{64} << 20);

}  // namespace circtest
