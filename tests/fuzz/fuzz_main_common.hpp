#pragma once
// What counts as a finding in every harness: a crash or sanitizer report (libFuzzer's own),
// and any exception other than circtest's documented input errors: an internal Error (exit
// 1: "a bug"), a std::exception that is not an Error, or an allocation beyond the input's
// size (libFuzzer's -malloc_limit_mb catches those).
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>

#include "circtest/core/error.hpp"

namespace circtest::fuzz {

template <class F>
void expect_documented_outcome(F&& body) {
  try {
    body();
  } catch (const Error& e) {
    if (e.code() == ExitCode::internal) {
      std::fprintf(stderr, "internal error on fuzz input: %s\n", e.what());
      std::abort();
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "unexpected exception on fuzz input: %s\n", e.what());
    std::abort();
  }
}

}  // namespace circtest::fuzz
