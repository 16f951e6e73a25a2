import numpy as np
import pytest

import silpose
from conftest import model


@pytest.fixture(scope="module")
def database(cli_database):
    return silpose.ViewDatabase.read(cli_database)


def test_match_finds_the_rendered_view(database):
    cow = silpose.load_mesh(model("cow"))
    view = 17
    direction = database.view_directions[view]
    mask = silpose.render_view(cow, direction, roll_deg=45.0, resolution=96)
    assert mask.shape == (96, 96) and mask.dtype == np.uint8 and set(np.unique(mask)) == {0, 255}
    matcher = silpose.Matcher(database)
    candidates = matcher.match(mask, top_k=3)
    assert len(candidates) == 3
    best = candidates[0]
    assert (best.model_name, best.model, best.view, best.shell) == ("cow", 0, view, 0)
    assert abs(best.roll_deg - 45.0) < 6.0
    assert best.score > 0.95 and best.score >= candidates[1].score >= candidates[2].score
    np.testing.assert_allclose(best.view_dir, direction)
    # The exhaustive search agrees; a signature from the database matches itself with score 1.
    assert matcher.match(mask, top_k=1, exhaustive=True)[0].view == view
    # (A compact database's signatures are derived from its spectra, so already smoothed once: the
    # matcher smooths them again, which leaves the score a little below 1.)
    own = matcher.match_signature(database.signatures(1)[0, 5], top_k=1)[0]
    assert (own.model_name, own.view) == ("hand", 5) and own.score == pytest.approx(1.0, abs=2e-3)
    # Any depth and channel count of mask is accepted: a 3-channel float mask gives the same.
    as_float = np.repeat((mask / 255.0).astype(np.float32)[:, :, None], 3, axis=2)
    assert matcher.match(as_float, top_k=1)[0].view == view


def test_match_refuses_an_empty_mask(database):
    with pytest.raises(silpose.Error, match="mask: no usable silhouette"):
        silpose.Matcher(database).match(np.zeros((96, 96), np.uint8))
    with pytest.raises(silpose.Error, match="signature"):
        silpose.Matcher(database).match_signature(np.ones(10, np.float32))


def test_render_pose_agrees_with_the_camera(database):
    cow = silpose.load_mesh(model("cow"))
    assert cow.name == "cow" and cow.vertices.shape[1] == 3 and cow.triangles.shape[1] == 3
    assert cow.radius > 0 and np.all(cow.triangles < len(cow.vertices))
    camera = silpose.Camera(320, 240, 300.0, 300.0, 159.5, 119.5)
    np.testing.assert_allclose(camera.matrix, [[300, 0, 159.5], [0, 300, 119.5], [0, 0, 1]])
    pose = silpose.camera_from_object_at_view([0, 0, 1], 0.0, 4.0 * cow.radius, cow.centre)
    np.testing.assert_allclose(pose[:3, :3] @ cow.centre + pose[:3, 3], [0, 0, 4.0 * cow.radius],
                               atol=1e-9)
    mask = silpose.render_pose(cow, camera, pose)
    assert mask.shape == (240, 320)
    ys, xs = np.nonzero(mask)
    # The bounding sphere projects to a disc of radius f / sqrt(15) around the principal point.
    reach = 300.0 / np.sqrt(15.0) + 1.0
    assert np.all(np.hypot(xs - 159.5, ys - 119.5) <= reach)
    assert len(xs) > 500
    with pytest.raises(silpose.Error, match="camera_from_object: the upper-left 3x3 block"):
        silpose.render_pose(cow, camera, np.diag([2.0, 1.0, 1.0, 1.0]))


def test_synthetic_sequence_frames_are_the_rendered_truth(tmp_path):
    meshes = [silpose.load_mesh(model("cow")), silpose.load_mesh(model("hand"))]
    sequence = silpose.SyntheticSequence(meshes, trajectory="walk", frames=6, seed=4,
                                         switch_every=3, colour=True)
    assert sequence.num_frames == 6
    assert sequence.background.shape == (480, 640, 3)
    for index in range(6):
        frame = sequence.generate(index)
        assert frame["object"] == ("cow" if index < 3 else "hand")
        rendered = silpose.render_pose(meshes[index // 3], sequence.camera,
                                       frame["camera_from_object"])
        np.testing.assert_array_equal(frame["mask"], rendered)
        assert frame["colour"].shape == (480, 640, 3)
        # Off the object, the colour frame is the background.
        off = frame["mask"] == 0
        np.testing.assert_array_equal(frame["colour"][off], sequence.background[off])
    report = sequence.write(tmp_path / "seq", threads=2)
    assert "6 frames" in report
    masks = list(silpose.FrameReader(str(tmp_path / "seq"), color="mask"))
    assert len(masks) == 6
    np.testing.assert_array_equal(masks[4], sequence.generate(4)["mask"])
    with pytest.raises(silpose.Error, match="trajectory must be"):
        silpose.SyntheticSequence(meshes, trajectory="spiral")
    with pytest.raises(silpose.Error, match="already holds a sequence|exists|overwrite"):
        sequence.write(tmp_path / "seq")


def test_matcher_keeps_its_database_alive(cli_database):
    import gc
    matcher = silpose.Matcher(silpose.ViewDatabase.read(cli_database))
    gc.collect()
    direction = matcher.database.view_directions[5]
    mask = silpose.render_view(silpose.load_mesh(model("hand")), direction, resolution=96)
    best = matcher.match(mask, top_k=1)[0]
    assert (best.model_name, best.view) == ("hand", 5)
