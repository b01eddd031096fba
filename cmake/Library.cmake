# A part's library, set up one way for every part:
#   circtest_add_library(<part> SOURCES src/a.cpp ... [PIC])
# makes circtest_<part> with the alias circtest::<part>, <part folder>/include as its public
# include folder (headers under include/circtest/<part>/), and fails the configure step when
# a .cpp under the part's src/, in any subfolder, is missing from SOURCES
# (circtest_check_listed "src/**/*.cpp"). PIC: position-
# independent code (for libraries that end up in a shared object). The libraries are not
# installed: the package installs only the programs, man pages and realtime modules.
# With CIRCTEST_UNITY_BUILD (default) the sources compile in batches of 8 (one compiler run
# each): the headers (nlohmann/json, Eigen, fmt) are parsed and their templates instantiated
# once per batch instead of once per file, which halves the libraries' compile time; a name
# defined in two sources of one library (even in an anonymous namespace) is then a compile
# error, which keeps helpers from being copied.
function(circtest_add_library part)
  cmake_parse_arguments(ARG "PIC" "" "SOURCES" ${ARGN})
  if(NOT ARG_SOURCES)
    message(FATAL_ERROR "circtest_add_library(${part}): no SOURCES")
  endif()
  circtest_check_listed("src/**/*.cpp" ${ARG_SOURCES})
  add_library(circtest_${part} ${ARG_SOURCES})
  add_library(circtest::${part} ALIAS circtest_${part})
  target_include_directories(circtest_${part} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  circtest_unity(circtest_${part})
  if(ARG_PIC)
    set_target_properties(circtest_${part} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  endif()
endfunction()

# TARGET's sources compiled a batch at a time when CIRCTEST_UNITY_BUILD is on (see above).
function(circtest_unity target)
  set_target_properties(${target} PROPERTIES UNITY_BUILD ${CIRCTEST_UNITY_BUILD}
                                             UNITY_BUILD_BATCH_SIZE 8)
endfunction()

# Sources are listed, never globbed. This check fails the configure step when a file matching
# PATTERN (relative to the calling folder) is missing from LISTED, so a new unit cannot be left
# out of the build unnoticed:   circtest_check_listed("bench_*.cpp" ${benches})
# A PATTERN "DIR/**/GLOB" matches GLOB in DIR and in every folder below it.
function(circtest_check_listed pattern)
  if(pattern MATCHES "^(.*)/[*][*]/([^/]*)$")
    file(GLOB_RECURSE present CONFIGURE_DEPENDS RELATIVE ${CMAKE_CURRENT_SOURCE_DIR}
         ${CMAKE_CURRENT_SOURCE_DIR}/${CMAKE_MATCH_1}/${CMAKE_MATCH_2})
  else()
    file(GLOB present CONFIGURE_DEPENDS RELATIVE ${CMAKE_CURRENT_SOURCE_DIR}
         ${CMAKE_CURRENT_SOURCE_DIR}/${pattern})
  endif()
  foreach(file ${present})
    if(NOT file IN_LIST ARGN)
      message(FATAL_ERROR "${CMAKE_CURRENT_SOURCE_DIR}/${file} is not listed in "
                          "${CMAKE_CURRENT_LIST_FILE}")
    endif()
  endforeach()
endfunction()
