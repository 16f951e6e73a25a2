#!/usr/bin/env python3
"""Per-frame overhead of tracking from Python over tracking in C++ (docs/PERFORMANCE.md).

The same frames (masks of a synthetic walk of the sample models, in memory) are tracked by two
fresh trackers of the same seed, which give identical results:
  C++:    tracker.process_many(frames): one call, the frame loop in C++;
  Python: for frame in frames: tracker.process(frame): one Python call and result per frame.
Both convert their results to Python objects; the difference is what a Python loop adds per
frame (call, argument and result conversion, GIL). The runs alternate, and the median of the
repeats is reported. Run with the build's package on PYTHONPATH:

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
    cpp, python, library = [], [], []
    for _ in range(arguments.repeats):
        seconds, results = cpp_loop()
        cpp.append(seconds)
        seconds, again = python_loop()
        python.append(seconds)
        library.append(sum(result.time_ms for result in again) / 1000.0)
        assert [r.camera_from_object is None for r in results] == \
               [r.camera_from_object is None for r in again]
    n = len(frames)
    cpp_ms = statistics.median(cpp) / n * 1000.0
    python_ms = statistics.median(python) / n * 1000.0
    library_ms = statistics.median(library) / n * 1000.0
    print(f"{database.num_models} models x {database.num_views} views x {database.num_shells} "
          f"shells, {n} frames of {camera.width}x{camera.height} masks, {arguments.repeats} runs")
    print(f"C++ loop (process_many): {cpp_ms:.3f} ms per frame")
    print(f"Python loop (process):   {python_ms:.3f} ms per frame")
    print(f"Tracker.Process itself:  {library_ms:.3f} ms per frame (time_ms)")
    print(f"Python overhead: {python_ms - cpp_ms:+.3f} ms per frame = "
          f"{100.0 * (python_ms - cpp_ms) / cpp_ms:+.2f} % (target <= 5 %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
