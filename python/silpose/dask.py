"""silpose on a Dask cluster: database building and tracking as parallel tasks (docs/python.md).

Needs dask.distributed (Debian: python3-distributed) and the silpose package importable on every
worker. The workers read the meshes, videos and database files themselves, by the paths given, so
the paths must name the same files on every worker (a shared file system); databases and results
travel back to the client.

    from distributed import Client
    import silpose.dask
    client = Client("tcp://scheduler:8786")
    silpose.dask.build_database(["parts/a.obj", "parts/b.obj"], "parts.db", client, views=1000)
    silpose.dask.track_videos(["cam1.avi", "cam2.avi"], "parts.db", "poses", client,
                              segment="bgsub", camera="camera.yml")
"""

import os
import tempfile
import uuid

import silpose

__all__ = ["build_database", "track_videos"]


def _build_shard(mesh_path, options):
    """Task: the database of one mesh, as the bytes of its file."""
    database = silpose.build_database([mesh_path], silpose.DatabaseOptions(**options))
    return database.to_bytes()


def build_database(mesh_paths, out, client, **options):
    """Builds the database of `mesh_paths` on the cluster of `client`: one task per model (a
    one-model shard, as 'silpose build-db MESH' makes it), then the shards are merged in the
    order of `mesh_paths` ('silpose merge-db') and written to `out`. The file is byte for byte
    what 'silpose build-db' of all the meshes at once writes. `options` are DatabaseOptions
    attributes (views=, distances=, signature_length=, resolution=, fill=, bins=,
    neighbour_radius=, threads=: threads per task, 0 = all cores of the worker). Returns the
    merged ViewDatabase. Raises silpose.Error for invalid options (before any task runs), a mesh
    that cannot be built (naming it) or model names that are not unique.
    """
    mesh_paths = [os.fspath(path) for path in mesh_paths]
    if not mesh_paths:
        raise silpose.Error("no model given: the database needs at least one mesh")
    silpose.DatabaseOptions(**options).check()
    stems = {}
    for path in mesh_paths:
        stem = os.path.splitext(os.path.basename(path))[0]
        if stem in stems:
            raise silpose.Error(f"{path}: another model is also named '{stem}' (model names are "
                                "file stems and must be unique)")
        stems[stem] = path
    futures = client.map(_build_shard, mesh_paths, options=dict(options), pure=False,
                         key=[f"silpose-build-{stem}-{uuid.uuid4().hex}" for stem in stems])
    shards = client.gather(futures)
    with tempfile.TemporaryDirectory(prefix="silpose-shards-") as folder:
        paths = []
        for index, data in enumerate(shards):
            path = os.path.join(folder, f"{index:06d}.db")
            with open(path, "wb") as file:
                file.write(data)
            paths.append(path)
        return silpose.merge_databases(paths, os.fspath(out))


# Databases read by this worker process, by (path, size, modification time): tracking several
# videos against one database reads it once per worker.
_databases = {}


def _database(source):
    if isinstance(source, bytes):
        return silpose.ViewDatabase.from_bytes(source, "<database from the client>")
    status = os.stat(source)
    key = (os.path.abspath(source), status.st_size, status.st_mtime_ns)
    if key not in _databases:
        _databases.clear()
        _databases[key] = silpose.ViewDatabase.read(source)
    return _databases[key]


def _track_one(video, output, database, camera, max_frames, options):
    """Task: tracks one video into `output` (POSES.csv); returns a summary dict."""
    os.makedirs(os.path.dirname(output) or ".", exist_ok=True)
    results = silpose.track_video(_database(database), video, output, camera=camera,
                                  options=silpose.TrackerOptions(**options),
                                  max_frames=max_frames)
    try:
        from distributed import get_worker
        worker = get_worker().address
    except (ImportError, ValueError):
        worker = None
    return {
        "video": video,
        "worker": worker,
        "poses": output,
        "frames": len(results),
        "measured": sum(1 for result in results if result.segmentation == "ok"),
    }


def _name(video):
    path = os.path.normpath(os.fspath(video))
    return os.path.splitext(os.path.basename(path))[0]


def track_videos(videos, database, outdir, client, camera=None, max_frames=0, **options):
    """Tracks each video (AVI file, image folder or sequence folder) as one task on the cluster
    of `client`, as 'silpose track' does, writing OUTDIR/<name>/POSES.csv per video (<name>: the
    file's stem or the folder's name, which must be unique). `database`: a database file path
    (read by each worker) or a ViewDatabase (sent to the workers). camera: a calibration file path
    for every video, or None (a sequence folder's camera.yml, else the default camera). `options`
    are TrackerOptions attributes (segment=, background=, seed=, refine=, ...). Returns one
    summary dict per video, in order: video, poses (the POSES.csv path), frames, measured (frames
    with a silhouette), worker (the address of the worker that tracked it). Raises silpose.Error for invalid options before any task runs, and the
    first task's error (naming the video) if one fails.
    """
    videos = [os.fspath(video) for video in videos]
    silpose.TrackerOptions(**options).check()
    names = {}
    for video in videos:
        name = _name(video)
        if name in names:
            raise silpose.Error(f"{video}: another video is also named '{name}' ({names[name]}): "
                                "their outputs would collide")
        names[name] = video
    if isinstance(database, silpose.ViewDatabase):
        database = client.scatter(database.to_bytes(), broadcast=True)
    else:
        database = os.path.abspath(os.fspath(database))
    if camera is not None:
        camera = os.path.abspath(os.fspath(camera))
    outdir = os.path.abspath(os.fspath(outdir))
    outputs = [os.path.join(outdir, _name(video), "POSES.csv") for video in videos]
    futures = client.map(_track_one, [os.path.abspath(v) for v in videos], outputs,
                         database=database, camera=camera, max_frames=max_frames,
                         options=dict(options), pure=False,
                         key=[f"silpose-track-{name}-{uuid.uuid4().hex}" for name in names])
    summaries = client.gather(futures)
    for summary, video in zip(summaries, videos):
        summary["video"] = video
    return summaries
