// jemalloc's settings for the programs that link circtest::malloc (cmake/Malloc.cmake).
//
// Why: a 1e6-row trace is held in columns and profiles of 4-14 MiB each. glibc's malloc maps
// each in its own 4 KiB pages, and on a virtual machine with shadow paging (the project's
// 2-core VM) a 4 KiB page fault costs ~35 us, so faulting in 64 MiB took 0.55 s against 6 ms
// in 2 MiB pages; `circana analyze` spent over half its CPU time there. jemalloc with
// transparent huge pages for all its memory (thp:always; the system setting "madvise" lets a
// process ask) cut the faults from 5,240 to 845 and analyze's CPU time by more than half on a
// .ctb trace.
//
// One arena (narenas:1): the analysis starts short-lived worker threads, and with jemalloc's
// default of 4 arenas per core each new thread went to another arena, whose memory was fresh
// again (a thread that allocated 160 KB cost ~600 us to start, against ~80 us with one arena),
// and memory freed in one arena was not reused by the next. `circana diagnose` on the 1e6-row
// .ctb: 0.28 -> 0.23 s. The workers allocate a few blocks each: the one arena's lock is not
// contended. MALLOC_CONF in the environment still overrides this (jemalloc(3)).
extern "C" {
// jemalloc reads this name at start-up: its own definition is weak.
// NOLINTNEXTLINE(cppcoreguidelines-avoid-non-const-global-variables)
const char* malloc_conf = "thp:always,metadata_thp:auto,narenas:1";
}
