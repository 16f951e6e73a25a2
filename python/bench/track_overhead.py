#!/usr/bin/env python3
"""Per-frame overhead of tracking from Python over tracking in C++ (docs/PERFORMANCE.md).

The same frames (masks of a synthetic walk of the sample models, in memory) are tracked by two
fresh trackers of the same seed, which give identical results:
  C++:    tracker.process_many(frames): one call, the frame loop in C++;
  Python: for frame in frames: tracker.process(frame): one Python call and result per frame.
Both convert their results to Python objects. Each frame's time outside Tracker::Process (the
run's wall time minus the frames' own time_ms) is what the binding costs; the Python loop's minus
the C++ loop's is what a Python loop adds per frame (call, argument and result conversion, GIL),
reported relative to the time of Tracker::Process. The runs alternate; medians of the repeats. Run with the build's package on PYTHONPATH:

  PYTHONPATH=build/py/python /usr/bin/python3 python/bench/track_overhead.py
"""

import argparse
import os
import statistics
import sys
import tempfile
import time

import silpose

SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--database", help="database file (default: build one of the sample models)")
    parser.add_argument("--views", type=int, default=300, help="views when building (default 300)")
    parser.add_argument("--frames", type=int, default=150, help="frames per run (default 150)")
    parser.add_argument("--repeats", type=int, default=5, help="runs of each kind (default 5)")
    arguments = parser.parse_args()

    models = os.path.join(SOURCE_DIR, "data", "models")
    meshes = [os.path.join(models, name + ".obj") for name in ("cow", "hand", "bunny")]
    with tempfile.TemporaryDirectory() as folder:
        if arguments.database:
            database = silpose.ViewDatabase.read(arguments.database)
        else:
            database = silpose.build_database(
                meshes, silpose.DatabaseOptions(views=arguments.views), os.path.join(folder, "b.db"))
    sequence = silpose.SyntheticSequence([silpose.load_mesh(path) for path in meshes],
                                         trajectory="walk", frames=arguments.frames)
    frames = [sequence.generate(i)["mask"] for i in range(sequence.num_frames)]
    camera = sequence.camera

    def cpp_loop():
        tracker = silpose.Tracker(database, camera)
        start = time.perf_counter()
        results = tracker.process_many(frames)
        return time.perf_counter() - start, results

    def python_loop():
        tracker = silpose.Tracker(database, camera)
        start = time.perf_counter()
        results = [tracker.process(frame) for frame in frames]
        return time.perf_counter() - start, results

    cpp_loop()  # warm up: spectra are computed on first use per database view
    # Per run: wall time per frame, and the time spent outside Tracker::Process (wall time minus
    # the library's own time_ms of each frame), which does not vary with the machine's load on
    # the pipeline itself.
    runs = {"cpp": [], "python": []}
    objects = None
    for _ in range(arguments.repeats):
        for kind, loop in (("cpp", cpp_loop), ("python", python_loop)):
            seconds, results = loop()
            inside = sum(result.time_ms for result in results) / 1000.0
            runs[kind].append((seconds / len(frames) * 1e3, (seconds - inside) / len(frames) * 1e3,
                               inside / len(frames) * 1e3))
            # Every run gives the same results (same seed, fresh tracker).
            names = [result.object_name for result in results]
            assert objects is None or names == objects
            objects = names

    def median(kind, field):
        return statistics.median(run[field] for run in runs[kind])

    process_ms = median("cpp", 2)
    print(f"{database.num_models} models x {database.num_views} views x {database.num_shells} "
          f"shells, {len(frames)} frames of {camera.width}x{camera.height} masks, "
          f"{arguments.repeats} runs of each loop, medians")
    for kind, label in (("cpp", "C++ loop (process_many)"), ("python", "Python loop (process)")):
        print(f"{label}: {median(kind, 0):.3f} ms per frame, of which outside Tracker::Process "
              f"{median(kind, 1) * 1e3:.1f} us")
    print(f"Tracker::Process itself: {process_ms:.3f} ms per frame")
    extra = median("python", 1) - median("cpp", 1)
    print(f"Python overhead per frame: {extra * 1e3:+.1f} us = {100.0 * extra / process_ms:+.2f} % "
          f"of the frame's processing (target <= 5 %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
