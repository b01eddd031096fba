#pragma once
// CIRCTEST_UNDER_ASAN is defined when the code under test, the libraries and the programs a
// test runs, is built with AddressSanitizer: CIRCTEST_SANITIZE_BUILD (cmake/Sanitize.cmake;
// a test program's own sources are not instrumented), or the test itself instrumented (GCC's
// __SANITIZE_ADDRESS__, clang's __has_feature): for the few checks ASan changes.
#if defined(CIRCTEST_SANITIZE_BUILD) || defined(__SANITIZE_ADDRESS__)
#define CIRCTEST_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CIRCTEST_UNDER_ASAN 1
#endif
#endif
