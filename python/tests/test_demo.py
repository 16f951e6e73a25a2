"""The Python tracker on the demo's own video gives the poses 'silpose demo' writes."""

import os

import silpose

from conftest import read_poses, run_cli


def test_python_tracker_on_the_demo_video_gives_the_demos_poses(tmp_path):
    out = tmp_path / "demo"
    # The demo's whole pipeline, smaller than its defaults (as the CLI's own demo test runs it).
    run_cli("demo", "-o", out, "--threads", "2", "--views", "400", "--frames-per-object", "40")
    sequence = out / "sequence"
    options = silpose.TrackerOptions(segment="bgsub", seed=1,
                                     background=os.fspath(sequence / "background.png"))
    results = silpose.track_video(out / "demo.db", sequence / "video.avi",
                                  output=tmp_path / "python_poses.csv",
                                  camera=sequence / "camera.yml", options=options)
    cli_rows = read_poses(out / "POSES.csv")
    assert len(results) == len(cli_rows) == 120
    # Every row, to the last printed digit (timing columns aside).
    assert read_poses(tmp_path / "python_poses.csv") == cli_rows
    assert sum(r.camera_from_object is not None for r in results) >= 100
