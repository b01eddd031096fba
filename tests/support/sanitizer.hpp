#pragma once
// CIRCTEST_UNDER_ASAN is defined when the test is built with AddressSanitizer (GCC's
// __SANITIZE_ADDRESS__, clang's __has_feature): for the few tests ASan cannot run.
#if defined(__SANITIZE_ADDRESS__)
#define CIRCTEST_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CIRCTEST_UNDER_ASAN 1
#endif
#endif
