#pragma once
// Worker thread counts for the parallel parts (database building, evaluation, synthesis).

namespace silpose {

/// Cores this process may run on (its CPU affinity), at least 1.
int AvailableCores();

/// The number of worker threads to use for a request: 0 = all available cores; more than the
/// available cores gains nothing (and oneTBB warns about it), so requests are capped there.
int WorkerThreads(int requested);

}  // namespace silpose
