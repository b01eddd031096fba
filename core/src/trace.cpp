// Reading a trace: a text given in memory, or a file (text or binary, by its magic).
#include "circtest/core/trace.hpp"

#include "trace_parser.hpp"

namespace circtest {

using namespace trace_detail;

Trace parse_trace(std::string_view text, const std::string& source,
                  const TraceReadOptions& options) {
  return parse_text(text, source, options, text_workers(options, text.size()));
}

Trace read_trace(const std::string& path, const TraceReadOptions& options) {
  const InputFile in(path);
  if (!in.regular()) return read_stream_text(in, options);
  char magic[sizeof kBinaryMagic] = {};
  if (in.size() >= sizeof magic &&
      read_exact(in.fd(), magic, sizeof magic, 0, path) == sizeof magic &&
      std::memcmp(magic, kBinaryMagic, sizeof magic) == 0) {
    return read_binary_trace(in, options);
  }
  if (in.size() == 0) return parse_text({}, path, options, 1);
  // One thread per idle core (or as asked) once the file is large. Idle, on 2 cores, a 1e6-row
  // CSV (71 MB) took 0.10-0.11 s in two streamed stretches against 0.16-0.19 s on one thread
  // (the floor of parsing every number on one thread: 0.16 s).
  const unsigned workers = worker_count(options, in.size());
  if (workers < 2) return read_stream_text(in, options, in.size());
  return read_text_stretches(in, options, workers);
}

}  // namespace circtest
