"""silpose: which known rigid object does the camera see, and where is it, from its silhouette.

Python bindings of the silpose library (docs/python.md). Arrays are numpy arrays: masks and frames
in (uint8, uint16 or float32; (H, W) or (H, W, 3) BGR), masks, poses (4x4) and directions out.
Bad input raises silpose.Error (a ValueError) with the library's message, which names the file or
value and the problem.

    import silpose
    database = silpose.ViewDatabase.read("parts.db")
    tracker = silpose.Tracker(database, silpose.Camera.read("camera.yml"),
                              silpose.TrackerOptions(segment="bgsub", background="empty.png"))
    for frame in silpose.FrameReader("recording.avi", masks=False):
        result = tracker.process(frame)
        print(result.object_name, result.score, result.camera_from_object)

silpose.dask runs database building and tracking as tasks on a Dask cluster.
"""

from silpose._silpose import (
    Camera,
    Candidate,
    DatabaseOptions,
    Error,
    FrameReader,
    Matcher,
    Mesh,
    PosesWriter,
    Smoother,
    SyntheticSequence,
    Tracker,
    TrackerOptions,
    TrackResult,
    ViewDatabase,
    build_database,
    camera_from_object_at_view,
    load_mesh,
    merge_databases,
    render_pose,
    render_view,
)

__all__ = [
    "Camera",
    "Candidate",
    "DatabaseOptions",
    "Error",
    "FrameReader",
    "Matcher",
    "Mesh",
    "PosesWriter",
    "Smoother",
    "SyntheticSequence",
    "Tracker",
    "TrackerOptions",
    "TrackResult",
    "ViewDatabase",
    "build_database",
    "camera_from_object_at_view",
    "load_mesh",
    "merge_databases",
    "render_pose",
    "render_view",
    "track_video",
]


def track_video(database, input, output=None, camera=None, options=None, max_frames=0, lag=0,
                smooth=False):
    """Tracks every frame of `input` as 'silpose track' does and returns the TrackResults.

    database: a ViewDatabase or a database file path. input: an AVI video, an image folder or a
    sequence folder ('silpose synth'). output: POSES.csv to write (optional). camera: a Camera, a
    calibration file path, or None: the sequence folder's camera.yml, else Camera.default() of the
    frames' size. options: TrackerOptions (default: frames are masks). For a sequence folder and
    segment='bgsub' without a background image, the folder's background.png is used, as
    'silpose track' does. max_frames: stop after this many frames (0 = all). lag (frames) or
    smooth: results smoothed by the particle histories, as 'silpose track --lag N' / '--smooth'
    (Smoother; the results still come back one per frame, in order).
    """
    import os

    if not isinstance(database, ViewDatabase):
        database = ViewDatabase.read(os.fspath(database))
    options = options if options is not None else TrackerOptions()
    input = os.fspath(input)
    is_folder = os.path.isdir(input)
    if (options.segment == "bgsub" and not options.background and is_folder
            and os.path.isfile(os.path.join(input, "background.png"))):
        options.background = os.path.join(input, "background.png")
    reader = FrameReader(input, masks=options.segment == "mask", read_ahead=2)
    if camera is None and is_folder and os.path.isfile(os.path.join(input, "camera.yml")):
        camera = os.path.join(input, "camera.yml")
    if camera is not None and not isinstance(camera, Camera):
        camera = Camera.read(os.fspath(camera))
    if smooth and lag:
        raise Error("give smooth or lag, not both")
    if lag < 0:
        raise Error(f"lag must be >= 0 frames (smooth=True for offline smoothing), got {lag}")
    writer = PosesWriter(os.fspath(output)) if output is not None else None
    results = []
    tracker = None
    frames = 0

    def emit(done):
        for result in done:
            results.append(result)
            if writer is not None:
                writer.write(result)

    try:
        for frame in reader:
            if tracker is None:
                height, width = frame.shape[:2]
                if camera is None:
                    camera = Camera.default(width, height)
                elif (camera.width, camera.height) != (width, height):
                    raise Error(f"the camera is {camera.width}x{camera.height} pixels but the "
                                f"frames of {input} are {width}x{height}: wrong calibration file?")
                if smooth or lag:
                    tracker = Smoother(database, camera, options,
                                       Smoother.OFFLINE if smooth else lag)
                else:
                    tracker = Tracker(database, camera, options)
            if isinstance(tracker, Smoother):
                emit(tracker.process(frame))
            else:
                emit([tracker.process(frame)])
            frames += 1
            if max_frames and frames >= max_frames:
                break
        if tracker is None:
            raise Error(f"{input}: no frames")
        if isinstance(tracker, Smoother):
            emit(tracker.finish())
    finally:
        if writer is not None:
            writer.close()
    return results
