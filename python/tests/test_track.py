import numpy as np
import pytest

import silpose
from conftest import cli_track, model, read_poses, run_cli


def rotation_angle_deg(a, b):
    cosine = (np.trace(a[:3, :3].T @ b[:3, :3]) - 1.0) / 2.0
    return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


def test_python_tracker_gives_the_poses_of_track(cli_database, video, tmp_path):
    cli_poses = read_poses(cli_track(cli_database, video, tmp_path / "cli.csv"))
    database = silpose.ViewDatabase.read(cli_database)
    camera = silpose.Camera.read(video / "camera.yml")
    options = silpose.TrackerOptions(segment="bgsub", background=str(video / "background.png"))
    tracker = silpose.Tracker(database, camera, options)
    results = []
    with silpose.PosesWriter(tmp_path / "py.csv") as writer:
        for frame in silpose.FrameReader(str(video / "video.avi"), masks=False):
            assert frame.shape == (480, 640, 3) and frame.dtype == np.uint8
            result = tracker.process(frame)
            writer.write(result)
            results.append(result)
    assert tracker.num_frames == len(cli_poses) == 12
    # The same rows, to the last printed digit (time_ms aside).
    assert read_poses(tmp_path / "py.csv") == cli_poses
    with_pose = 0
    for result, row in zip(results, cli_poses):
        assert result.frame == int(row["frame"])
        assert result.status == row["status"]
        assert (result.object_name or "") == row["object"]
        if result.camera_from_object is None:
            assert row["r00"] == ""
            continue
        with_pose += 1
        pose = result.camera_from_object
        assert pose.shape == (4, 4)
        np.testing.assert_array_equal(pose[3], [0, 0, 0, 1])
        expected = np.array([[float(row[f"r{i}{j}"]) for j in range(3)] for i in range(3)])
        np.testing.assert_allclose(pose[:3, :3], expected, atol=1e-5)
        np.testing.assert_allclose(pose[:3, 3], [float(row[k]) for k in ("tx", "ty", "tz")],
                                   rtol=1e-5, atol=1e-6)
        assert result.score == pytest.approx(float(row["score"]), abs=1e-5)
        assert result.probability == pytest.approx(float(row["probability"]), abs=1e-5)
        assert result.roll_deg == pytest.approx(float(row["roll_deg"]), abs=1e-4)
        np.testing.assert_allclose(result.view_dir,
                                   [float(row[k]) for k in ("view_x", "view_y", "view_z")],
                                   atol=1e-5)
    assert with_pose >= 8
    # The convenience loop does the same.
    again = silpose.track_video(database, video / "video.avi", tmp_path / "again.csv",
                                camera=video / "camera.yml",
                                options=options)
    assert len(again) == 12
    assert read_poses(tmp_path / "again.csv") == cli_poses


def test_tracker_on_masks_finds_the_object_and_pose(cli_database, tmp_path):
    mesh = silpose.load_mesh(model("hand"))
    sequence = silpose.SyntheticSequence([mesh], trajectory="orbit", frames=10)
    database = silpose.ViewDatabase.read(cli_database)
    tracker = silpose.Tracker(database, sequence.camera)
    results = tracker.process_many([sequence.generate(i)["mask"] for i in range(10)])
    assert [r.frame for r in results] == list(range(10))
    assert all(r.object_name == "hand" for r in results[3:])
    for index, result in enumerate(results[3:], start=3):
        truth = sequence.truth(index)
        assert rotation_angle_deg(result.camera_from_object, truth["camera_from_object"]) < 20
        distance = np.linalg.norm(truth["camera_from_object"][:3, 3])
        assert np.linalg.norm(result.camera_from_object[:3, 3] -
                              truth["camera_from_object"][:3, 3]) < 0.15 * distance
        assert result.mask.shape == (480, 640) and result.segmentation == "ok"
        assert not result.mask.flags.owndata  # a view of the library's mask
        assert 0.0 <= result.confidence <= 1.0
        assert result.state in ("tracking", "ambiguous", "unknown-object", "bad-segmentation",
                                "lost")
        assert 0.0 < result.iou <= 1.0
    # A clean orbit of a database object: trusted once identified.
    assert sum(r.state == "tracking" for r in results[3:]) >= 5


def test_a_frame_without_silhouette_has_no_pose(cli_database):
    tracker = silpose.Tracker(silpose.ViewDatabase.read(cli_database), silpose.Camera.default(64, 48))
    result = tracker.process(np.zeros((48, 64), np.uint8))
    assert result.camera_from_object is None and result.object_name is None
    assert result.score is None and result.view_dir is None and result.roll_deg is None
    assert result.segmentation == "empty" and result.status.startswith("predicted")
    assert result.state == "no-silhouette" and result.confidence is None
    assert result.runner_up is None


def test_tracker_keeps_its_database_alive(cli_database):
    tracker = silpose.Tracker(silpose.ViewDatabase.read(cli_database), silpose.Camera.default(96, 96))
    import gc
    gc.collect()
    mask = silpose.render_view(silpose.load_mesh(model("cow")), [1.0, 0.2, 0.3], resolution=96)
    assert tracker.process(mask).object_name == "cow"
    assert tracker.database.model_names == ["cow", "hand"]


def test_bad_frames_raise_with_the_library_message(cli_database):
    tracker = silpose.Tracker(silpose.ViewDatabase.read(cli_database), silpose.Camera.default(64, 48))
    with pytest.raises(silpose.Error, match="64x48|64 x 48|size"):
        tracker.process(np.zeros((50, 64), np.uint8))
    with pytest.raises(silpose.Error, match="frame: numpy arrays of dtype float64 are not supported"):
        tracker.process(np.zeros((48, 64)))
    with pytest.raises(silpose.Error, match="frame: .* not contiguous"):
        tracker.process(np.zeros((48, 128), np.uint8)[:, ::2])
    with pytest.raises(silpose.Error, match="frame: expected an array of shape"):
        tracker.process(np.zeros(10, np.uint8))
    # More particles than the adaptive cap's default: the floor and cap follow, as with --particles.
    many = silpose.TrackerOptions(particles_per_object=400)
    many.check()
    assert many.particles_per_object == 400
    with pytest.raises(silpose.Error, match="particles"):
        silpose.TrackerOptions(particles_per_object=0).check()
    # Fit arbitration: on by default, off at ratio 0, a ratio above 1 refused.
    assert silpose.TrackerOptions().fit_arbitration_ratio == 0.8
    silpose.TrackerOptions(fit_arbitration_ratio=0.0).check()
    with pytest.raises(silpose.Error, match="fit_arbitration_ratio"):
        silpose.TrackerOptions(fit_arbitration_ratio=1.5).check()
    # Its IoU and score-gap alternatives: on by default, 0 = off, out of range refused.
    assert silpose.TrackerOptions().fit_arbitration_iou_gain == pytest.approx(0.01)
    assert silpose.TrackerOptions().fit_arbitration_score_gap == pytest.approx(0.3)
    silpose.TrackerOptions(fit_arbitration_iou_gain=0.0, fit_arbitration_score_gap=0.0).check()
    with pytest.raises(silpose.Error, match="fit_arbitration_iou_gain"):
        silpose.TrackerOptions(fit_arbitration_iou_gain=-0.5).check()
    with pytest.raises(silpose.Error, match="fit_arbitration_score_gap"):
        silpose.TrackerOptions(fit_arbitration_score_gap=3.0).check()
    # The motion start: on by default, and can be switched off.
    assert silpose.TrackerOptions().refine_from_motion is True
    assert silpose.TrackerOptions(refine_from_motion=False).refine_from_motion is False
    # The view polish: two steps by default, 0 = off, out of range refused.
    assert silpose.TrackerOptions().polish_steps == 2
    silpose.TrackerOptions(polish_steps=0).check()
    with pytest.raises(silpose.Error, match="polish_steps"):
        silpose.TrackerOptions(polish_steps=-1).check()
    # The mirror-twin check: on by default, and can be switched off.
    assert silpose.TrackerOptions().mirror_twin_check is True
    assert silpose.TrackerOptions(mirror_twin_check=False).mirror_twin_check is False
    with pytest.raises(silpose.Error, match="TrackerOptions: unknown option 'segmnt'"):
        silpose.TrackerOptions(segmnt="bgsub")
    with pytest.raises(silpose.Error, match="'bgsubtraction'"):
        silpose.TrackerOptions(segment="bgsubtraction")
    assert silpose.TrackerOptions().background_method == "mog2"
    assert silpose.TrackerOptions(background_method="gauss").background_method == "gauss"
    with pytest.raises(silpose.Error, match="'gaussian'"):
        silpose.TrackerOptions(background_method="gaussian")
    with pytest.raises(silpose.Error, match="no-such-video.avi"):
        silpose.FrameReader("no-such-video.avi")
    with pytest.raises(silpose.Error, match="read_ahead must be >= 0"):
        silpose.FrameReader("no-such-video.avi", read_ahead=-1)
    with pytest.raises(silpose.Error, match="invalid camera"):
        silpose.Camera(0, 48, 50, 50, 32, 24)


def test_frames_read_ahead_are_the_frames_read_when_asked_for(video):
    plain = list(silpose.FrameReader(str(video / "video.avi"), masks=False))
    reader = silpose.FrameReader(str(video / "video.avi"), masks=False, read_ahead=3)
    ahead = list(reader)
    assert len(plain) == len(ahead) == 12
    assert reader.name == "video.avi#11"
    for a, b in zip(plain, ahead):
        np.testing.assert_array_equal(a, b)
    # Each frame is a buffer of its own: the first is intact after the last was read.
    assert not np.shares_memory(ahead[0], ahead[-1])


def test_smoother_reports_every_frame_late_and_in_order(cli_database, video, tmp_path):
    database = silpose.ViewDatabase.read(cli_database)
    mesh = silpose.load_mesh(model("cow"))
    sequence = silpose.SyntheticSequence([mesh], trajectory="walk", frames=16, seed=3)
    masks = [sequence.generate(i)["mask"] for i in range(16)]
    plain = silpose.Tracker(database, sequence.camera).process_many(masks)
    # Without the particle histories the tracker reports the same poses.
    lean_options = silpose.TrackerOptions(keep_history=False)
    assert not lean_options.keep_history and silpose.TrackerOptions().keep_history
    lean = silpose.Tracker(database, sequence.camera, lean_options).process_many(masks)
    assert [(r.object_name, r.view_dir.tolist(), r.roll_deg) for r in lean] == \
        [(r.object_name, r.view_dir.tolist(), r.roll_deg) for r in plain]

    smoother = silpose.Smoother(database, sequence.camera, lag=4)
    assert smoother.lag == 4
    out = []
    for index, mask in enumerate(masks):
        done = smoother.process(mask)
        assert [r.frame for r in done] == ([] if index < 4 else [index - 4])
        out += done
    assert smoother.num_pending == 4 and smoother.num_frames == 16
    out += smoother.finish()
    assert [r.frame for r in out] == list(range(16))
    # A frame the smoothing did not re-pose is reported as tracked.
    unchanged = sum(a.object_name == b.object_name and a.view_dir.tolist() == b.view_dir.tolist()
                    for a, b in zip(out, plain))
    assert unchanged + smoother.num_revised == 16
    # Frames kept as tracked because their live pose fitted better are among the unchanged ones.
    assert isinstance(smoother.num_kept_live, int) and 0 <= smoother.num_kept_live <= unchanged
    assert all(r.object_name == "cow" for r in out[4:])

    offline = silpose.Smoother(database, sequence.camera, lag=silpose.Smoother.OFFLINE)
    assert all(offline.process(mask) == [] for mask in masks)
    assert [r.frame for r in offline.finish()] == list(range(16))

    # A smoother keeps the histories it reads, whatever the options say.
    kept = silpose.Smoother(database, sequence.camera, lean_options, lag=2)
    assert [r.frame for mask in masks[:5] for r in kept.process(mask)] == [0, 1, 2]

    with pytest.raises(silpose.Error, match="brute force"):
        silpose.Smoother(database, sequence.camera, silpose.TrackerOptions(brute_force=True))
    with pytest.raises(silpose.Error, match="lag"):
        silpose.Smoother(database, sequence.camera, lag=-5)

    # track_video with a lag gives the rows of 'silpose track --lag'.
    cli = tmp_path / "cli.csv"
    run_cli("track", "-d", cli_database, video / "video.avi", "--camera", video / "camera.yml",
            "--segment", "bgsub", "--background", video / "background.png", "-o", cli,
            "--lag", 3)
    options = silpose.TrackerOptions(segment="bgsub", background=str(video / "background.png"))
    results = silpose.track_video(database, video / "video.avi", tmp_path / "py.csv",
                                  camera=video / "camera.yml", options=options, lag=3)
    assert [r.frame for r in results] == list(range(12))
    assert read_poses(tmp_path / "py.csv") == read_poses(cli)
    with pytest.raises(silpose.Error, match="not both"):
        silpose.track_video(database, video / "video.avi", options=options, lag=3, smooth=True)
    with pytest.raises(silpose.Error, match="lag must be >= 0"):
        silpose.track_video(database, video / "video.avi", options=options, lag=-1)


def test_one_gaussian_background_gives_the_poses_of_track(cli_database, video, tmp_path):
    """--bg-method gauss from Python: the rows of 'silpose track --bg-method gauss'."""
    cli = tmp_path / "cli.csv"
    run_cli("track", "-d", cli_database, video / "video.avi", "--camera", video / "camera.yml",
            "--segment", "bgsub", "--bg-method", "gauss", "--background",
            video / "background.png", "-o", cli)
    options = silpose.TrackerOptions(segment="bgsub", background_method="gauss",
                                     background=str(video / "background.png"))
    tracker = silpose.Tracker(silpose.ViewDatabase.read(cli_database),
                              silpose.Camera.read(video / "camera.yml"), options)
    with silpose.PosesWriter(tmp_path / "py.csv") as writer:
        for frame in silpose.FrameReader(str(video / "video.avi"), masks=False):
            writer.write(tracker.process(frame))
    rows = read_poses(cli)
    assert read_poses(tmp_path / "py.csv") == rows
    assert sum(row["object"] != "" for row in rows) >= len(rows) - 2
