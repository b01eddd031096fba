# CIRCTEST_SANITIZE: AddressSanitizer + UndefinedBehaviorSanitizer on every target that links
# circtest::options (all of them), stopping at the first finding. Under clang also
# float-cast-overflow, so a double converted to an integer it does not fit is a failure.
# CIRCTEST_FUZZ: coverage instrumentation for libFuzzer on the same targets (clang only);
# the harnesses in tests/fuzz link -fsanitize=fuzzer.
if(CIRCTEST_SANITIZE)
  set(circtest_sanitize_flags -fsanitize=address,undefined -fno-sanitize-recover=all
      -fno-omit-frame-pointer)
  if(CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    list(APPEND circtest_sanitize_flags -fsanitize=float-cast-overflow)
  endif()
  target_compile_options(circtest_options INTERFACE ${circtest_sanitize_flags})
  target_link_options(circtest_options INTERFACE ${circtest_sanitize_flags})
endif()
if(CIRCTEST_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "CIRCTEST_FUZZ needs clang (libFuzzer): -DCMAKE_CXX_COMPILER=clang++")
  endif()
  target_compile_options(circtest_options INTERFACE -fsanitize=fuzzer-no-link)
endif()
