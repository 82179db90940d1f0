#pragma once
/// \file
/// Freed memory kept in the process (glibc's mallopt), for a program that cuts while it runs.

namespace lamina {

/// From now on glibc keeps what is freed for the next allocation instead of unmapping or
/// trimming it: a cut event frees and allocates tens of megabytes (the model and simulation of
/// the cut organ made again), and fresh pages cost their page faults each time (26 of a 77 ms
/// cut event at 48k nodes), while the munmaps of a cut made on another thread stalled the
/// stepping thread's faults by up to 50 ms (docs/benchmarks.md). The process's resident memory
/// then no longer shrinks when a model is freed. Process-wide; idempotent.
void keep_freed_memory();

}  // namespace lamina
