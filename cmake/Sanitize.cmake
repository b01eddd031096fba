# CIRCTEST_SANITIZE: AddressSanitizer + UndefinedBehaviorSanitizer on every target that links
# circtest::options (all of them), stopping at the first finding. Under clang also
# float-cast-overflow, so a double converted to an integer it does not fit is a failure.
# Three UBSan checks are left out, each covered by ASan or moot here, for a third less compile
# time on the Eigen-heavy sources (analysis: 41.9 -> 27.0 s a batch): object-size (ASan checks
# every access against its object), pointer-overflow (address-space wrap-around; an index
# past an array is ASan's), vptr (calls on an object of the wrong dynamic type: the code
# has no downcasts of polymorphic types, and a call on a freed one is ASan's use-after-free).
# CIRCTEST_FUZZ: coverage instrumentation for libFuzzer on the same targets (clang only);
# the harnesses in tests/fuzz link -fsanitize=fuzzer.
# The test programs' own sources (targets with the property CIRCTEST_TEST_PROGRAM, set by
# circtest_add_gtest) get UBSan but neither ASan's nor libFuzzer's instrumentation: the code
# under test, the libraries, is instrumented, and a test program's heap is still ASan's (its
# runtime is linked in), while the GoogleTest files, the heaviest of the build, compile in
# half the time.
set(circtest_not_test_program "$<NOT:$<BOOL:$<TARGET_PROPERTY:CIRCTEST_TEST_PROGRAM>>>")
if(CIRCTEST_SANITIZE)
  set(circtest_sanitize_flags -fsanitize=undefined -fno-sanitize-recover=all
      -fno-omit-frame-pointer -fno-sanitize=pointer-overflow,object-size,vptr)
  if(CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    list(APPEND circtest_sanitize_flags -fsanitize=float-cast-overflow)
  endif()
  target_compile_options(circtest_options INTERFACE ${circtest_sanitize_flags}
                         $<${circtest_not_test_program}:-fsanitize=address>)
  target_link_options(circtest_options INTERFACE ${circtest_sanitize_flags} -fsanitize=address)
  # Tells a test program, whose own sources are not ASan-instrumented, that the programs it
  # runs are (tests/support/sanitizer.hpp).
  target_compile_definitions(circtest_options INTERFACE CIRCTEST_SANITIZE_BUILD=1)
endif()
if(CIRCTEST_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "CIRCTEST_FUZZ needs clang (libFuzzer): -DCMAKE_CXX_COMPILER=clang++")
  endif()
  target_compile_options(circtest_options INTERFACE
                         $<${circtest_not_test_program}:-fsanitize=fuzzer-no-link>)
endif()
