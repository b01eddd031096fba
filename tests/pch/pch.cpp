// The precompiled headers of the GoogleTest programs (tests/CMakeLists.txt) are built with
// this target's settings; it compiles nothing else.
