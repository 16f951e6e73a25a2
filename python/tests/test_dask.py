"""silpose.dask on a local cluster of two worker processes, one thread each."""

import pytest

distributed = pytest.importorskip("distributed")

import silpose
import silpose.dask
from conftest import DB_OPTIONS, make_video, model, read_poses, run_cli

# Debian 12's distributed with its tornado warns about tornado's own API; not ours to fix.
pytestmark = pytest.mark.filterwarnings("ignore:make_current is deprecated:DeprecationWarning")


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            yield client


def test_build_database_equals_build_db(client, cli_database, tmp_path):
    options = dict(DB_OPTIONS, threads=1)
    database = silpose.dask.build_database([model("cow"), model("hand")], tmp_path / "dask.db",
                                           client, **options)
    assert database.model_names == ["cow", "hand"]
    assert (tmp_path / "dask.db").read_bytes() == cli_database.read_bytes()
    with pytest.raises(silpose.Error, match="DatabaseOptions: unknown option 'viewz'"):
        silpose.dask.build_database([model("cow")], tmp_path / "x.db", client, viewz=3)
    with pytest.raises(silpose.Error, match="nothing.obj"):
        silpose.dask.build_database([tmp_path / "nothing.obj"], tmp_path / "x.db", client,
                                    **options)


def test_track_videos_equals_track(client, cli_database, tmp_path):
    # Four short colour sequences (folders of frames with their background.png and camera.yml,
    # which 'silpose track' and the tasks both use), tracked with background subtraction.
    videos = [make_video(tmp_path / f"v{seed}", seed=seed, frames=8) for seed in range(4)]
    summaries = silpose.dask.track_videos(videos, cli_database, tmp_path / "out", client,
                                          segment="bgsub")
    assert [s["frames"] for s in summaries] == [8] * 4
    assert all(s["measured"] >= 6 for s in summaries)
    for video, summary in zip(videos, summaries):
        assert summary["poses"] == str(tmp_path / "out" / video.name / "POSES.csv")
        expected = tmp_path / f"{video.name}.csv"
        run_cli("track", "-d", cli_database, video, "--segment", "bgsub", "-o", expected)
        assert read_poses(summary["poses"]) == read_poses(expected)
    # The two workers shared the videos; each keeps one database in memory.
    assert len({s["worker"] for s in summaries}) == 2
    counts = client.run(lambda: len(__import__("silpose.dask").dask._databases))
    assert sorted(counts.values()) == [1, 1]
    with pytest.raises(silpose.Error, match="also named 'v0'"):
        silpose.dask.track_videos([videos[0], videos[0]], cli_database, tmp_path / "o", client)
    with pytest.raises(silpose.Error, match="TrackerOptions: unknown option 'segmnt'"):
        silpose.dask.track_videos(videos, cli_database, tmp_path / "o", client, segmnt="bgsub")
    # A failing task's error reaches the caller with the library's message.
    with pytest.raises(silpose.Error, match="missing"):
        silpose.dask.track_videos([tmp_path / "missing"], cli_database, tmp_path / "o", client)
