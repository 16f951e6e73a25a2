"""One Tracker, Smoother, Matcher or FrameReader used from several Python threads at once: the
calls take turns (they run with the GIL released), so nothing is corrupted and nothing is lost."""

import threading

import numpy as np

import silpose
from conftest import model


def run_in_threads(count, work):
    errors = []

    def run(index):
        try:
            work(index)
        except BaseException as error:  # noqa: B902 - reported below, with the thread's index
            errors.append((index, repr(error)))

    threads = [threading.Thread(target=run, args=(i,)) for i in range(count)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []


def masks_of_a_walk(frames=12):
    mesh = silpose.load_mesh(model("cow"))
    sequence = silpose.SyntheticSequence([mesh], trajectory="walk", frames=frames, seed=5)
    return sequence.camera, [sequence.generate(i)["mask"] for i in range(frames)]


def test_a_tracker_shared_by_threads_processes_every_frame_once(cli_database):
    database = silpose.ViewDatabase.read(cli_database)
    camera, masks = masks_of_a_walk()
    tracker = silpose.Tracker(database, camera)
    frames = [[] for _ in range(3)]

    def work(index):
        for mask in masks:
            frames[index].append(tracker.process(mask).frame)
        frames[index].extend(r.frame for r in tracker.process_many(masks[:4]))

    run_in_threads(3, work)
    total = 3 * (len(masks) + 4)
    assert tracker.num_frames == total
    # Every call got a frame of its own, in the order each thread made its calls.
    assert sorted(f for thread in frames for f in thread) == list(range(total))
    assert all(thread == sorted(thread) for thread in frames)


def test_a_smoother_shared_by_threads_reports_every_frame_once(cli_database):
    database = silpose.ViewDatabase.read(cli_database)
    camera, masks = masks_of_a_walk()
    smoother = silpose.Smoother(database, camera, lag=3)
    out = [[] for _ in range(2)]

    def work(index):
        for mask in masks:
            out[index] += smoother.process(mask)
            assert smoother.num_pending <= 3

    run_in_threads(2, work)
    rest = smoother.finish()
    assert smoother.num_frames == 2 * len(masks)
    reported = [r.frame for thread in out for r in thread] + [r.frame for r in rest]
    assert sorted(reported) == list(range(2 * len(masks)))


def test_a_matcher_shared_by_threads_gives_each_mask_its_own_matches(cli_database):
    database = silpose.ViewDatabase.read(cli_database)
    _, masks = masks_of_a_walk(6)
    matcher = silpose.Matcher(database)
    expected = [[(c.model, c.view) for c in matcher.match(mask, top_k=3)] for mask in masks]
    got = [None] * 4

    def work(index):
        got[index] = [[(c.model, c.view) for c in matcher.match(mask, top_k=3)]
                      for mask in masks]

    run_in_threads(4, work)
    assert got == [expected] * 4


def test_a_frame_reader_shared_by_threads_hands_out_each_frame_once(video):
    plain = [frame.tobytes() for frame in silpose.FrameReader(str(video / "video.avi"),
                                                              masks=False)]
    for read_ahead in (0, 2):
        reader = silpose.FrameReader(str(video / "video.avi"), masks=False, read_ahead=read_ahead)
        taken = [[] for _ in range(3)]

        def work(index):
            for frame in reader:
                assert isinstance(frame, np.ndarray) and reader.name.startswith("video.avi#")
                taken[index].append(frame.tobytes())

        run_in_threads(3, work)
        assert sorted(f for thread in taken for f in thread) == sorted(plain)
        assert reader.num_frames == len(plain) == 12
