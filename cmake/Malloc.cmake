# circtest::malloc: linked into the programs that hold 1e6-row traces (circana, the reader's
# benchmark). With CIRCTEST_JEMALLOC it links jemalloc with transparent huge pages on
# (core/malloc/jemalloc_conf.cpp); otherwise, and under the sanitizers (whose allocator must
# stay in place), it is empty and glibc's malloc serves. docs/performance.md has the figures.
add_library(circtest_malloc INTERFACE)
add_library(circtest::malloc ALIAS circtest_malloc)
if(CIRCTEST_JEMALLOC AND NOT CIRCTEST_SANITIZE)
  find_library(CIRCTEST_JEMALLOC_LIBRARY NAMES jemalloc REQUIRED)  # Debian: libjemalloc-dev
  target_sources(circtest_malloc INTERFACE ${PROJECT_SOURCE_DIR}/core/malloc/jemalloc_conf.cpp)
  target_link_libraries(circtest_malloc INTERFACE ${CIRCTEST_JEMALLOC_LIBRARY})
endif()
