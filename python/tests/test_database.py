import subprocess

import numpy as np
import pytest

import silpose
from conftest import CLI, CLI_ENV, DB_OPTIONS, model, run_cli


def test_read_exposes_the_database(cli_database):
    database = silpose.ViewDatabase.read(cli_database)
    assert database.model_names == ["cow", "hand"]
    assert database.num_models == 2
    assert (database.num_views, database.num_shells, database.signature_length) == (60, 2, 120)
    assert database.distances == [3.0, 7.0]
    assert database.find_model("hand") == 1 and database.find_model("bunny") == -1
    directions = database.view_directions
    assert directions.shape == (60, 3) and directions.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, atol=1e-12)
    assert not directions.flags.writeable and not directions.flags.owndata
    signatures = database.signatures(1)
    assert signatures.shape == (2, 60, 120) and signatures.dtype == np.float32
    usable = signatures.sum(axis=2) > 0
    assert usable.mean() > 0.9
    # Each usable view's radii are divided by their mean.
    np.testing.assert_allclose(signatures[usable].mean(axis=1), 1.0, atol=1e-3)
    assert database.to_bytes() == cli_database.read_bytes()
    with pytest.raises(silpose.Error, match="model index 2 out of range"):
        database.signatures(2)


def test_symmetries_found_by_build_db(cli_database):
    database = silpose.ViewDatabase.read(cli_database)
    cow = database.symmetry(0)
    # The cow is mirror-symmetric in its plane z = const and turns onto itself about no axis.
    assert cow["discrete"] == [] and cow["continuous"] == []
    assert len(cow["mirrors"]) == 1
    assert abs(abs(cow["mirrors"][0]["normal"][2]) - 1.0) < 0.01
    assert "mirror plane" in cow["description"]
    assert database.symmetry(1)["description"] == "none"
    with pytest.raises(silpose.Error, match="model index 2 out of range"):
        database.symmetry(2)


def test_views_outlive_the_database_object(cli_database):
    directions = silpose.ViewDatabase.read(cli_database).view_directions
    # The database is only referenced by the array now.
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, atol=1e-12)


def test_build_database_equals_build_db(cli_database, tmp_path):
    options = silpose.DatabaseOptions(**DB_OPTIONS)
    assert options.views == 60 and options.distances == [3.0, 7.0]
    out = tmp_path / "py.db"
    database = silpose.build_database([model("cow"), model("hand")], options, out)
    assert database.model_names == ["cow", "hand"]
    assert out.read_bytes() == cli_database.read_bytes()


def test_merge_databases_equals_build_db(cli_database, tmp_path):
    options = silpose.DatabaseOptions(**DB_OPTIONS)
    silpose.build_database([model("cow")], options, tmp_path / "cow.db")
    run_cli("build-db", model("hand"), "-o", tmp_path / "hand.db", "--views", 60, "--resolution",
            96, "--signature-length", 120, "--distances", "3,7", "--bins", 4)
    merged = silpose.merge_databases([tmp_path / "cow.db", tmp_path / "hand.db"],
                                     tmp_path / "merged.db")
    assert merged.model_names == ["cow", "hand"]
    assert (tmp_path / "merged.db").read_bytes() == cli_database.read_bytes()
    run_cli("merge-db", tmp_path / "cow.db", tmp_path / "hand.db", "-o", tmp_path / "cli-merged.db")
    assert (tmp_path / "cli-merged.db").read_bytes() == cli_database.read_bytes()


def test_merge_refuses_other_parameters_naming_the_file(tmp_path):
    silpose.build_database([model("cow")], silpose.DatabaseOptions(**DB_OPTIONS), tmp_path / "a.db")
    other = dict(DB_OPTIONS, views=50)
    silpose.build_database([model("hand")], silpose.DatabaseOptions(**other), tmp_path / "b.db")
    with pytest.raises(silpose.Error, match=r"b\.db: built with other parameters .*--views: 60 vs 50"):
        silpose.merge_databases([tmp_path / "a.db", tmp_path / "b.db"])
    completed = subprocess.run(
        [CLI, "merge-db", tmp_path / "a.db", tmp_path / "b.db",
         "-o", tmp_path / "c.db"], capture_output=True, text=True, env=CLI_ENV)
    assert completed.returncode != 0
    assert "b.db: built with other parameters" in completed.stderr
    assert completed.stderr.count("\n") == 1
    assert not (tmp_path / "c.db").exists()


def test_bad_database_input_raises_with_the_library_message(tmp_path, cli_database):
    with pytest.raises(silpose.Error, match="missing.db: no such file"):
        silpose.ViewDatabase.read(tmp_path / "missing.db")
    truncated = tmp_path / "truncated.db"
    truncated.write_bytes(cli_database.read_bytes()[:1000])
    with pytest.raises(silpose.Error, match="truncated.db: truncated database"):
        silpose.ViewDatabase.read(truncated)
    with pytest.raises(silpose.Error, match="<mine>: not a silpose view database"):
        silpose.ViewDatabase.from_bytes(b"hello", "<mine>")
    with pytest.raises(silpose.Error, match="DatabaseOptions: unknown option 'view'"):
        silpose.DatabaseOptions(view=3)
    with pytest.raises(silpose.Error, match="invalid database options"):
        silpose.DatabaseOptions(distances=[3.0, 2.0]).check()
    with pytest.raises(silpose.Error, match="nothing.obj"):
        silpose.build_database([tmp_path / "nothing.obj"], silpose.DatabaseOptions(**DB_OPTIONS))
    assert issubclass(silpose.Error, ValueError)
