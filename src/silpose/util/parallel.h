#pragma once
// The parallel loop of the project's threaded work (database building): oneTBB's parallel_for in
// a task arena of the requested size, or, in builds for ThreadSanitizer, std::thread workers.
//
// Why two: Debian's libtbb is not built with -fsanitize=thread, so ThreadSanitizer cannot see the
// ordering that libtbb provides and reports every result read after a parallel_for as a race. A
// build configured with SILPOSE_SANITIZERS=thread (the 'tsan' preset) compiles this file with
// SILPOSE_PARALLEL_STD_THREADS: the same loop bodies then run on std::thread workers that take
// chunks of indices from a shared counter, and TSan checks what the bodies share.

#include <functional>

namespace silpose {

/// Calls body(chunk_begin, chunk_end) for consecutive chunks of at most `grain` (>= 1) indices
/// that together cover [begin, end) once, on up to WorkerThreads(num_threads) threads (0 = all
/// cores), and returns when all are done. `beside`, if given, runs once on one of the threads,
/// concurrently with the chunks. If body or beside throws, the remaining chunks may be skipped
/// and the first exception is rethrown once every thread has stopped.
void ParallelFor(int begin, int end, int grain, int num_threads,
                 const std::function<void(int, int)>& body,
                 const std::function<void()>& beside = {});

/// Which implementation ParallelFor uses: "tbb" or "std::thread".
const char* ParallelBackend();

}  // namespace silpose
