"""Shared fixtures: the silpose CLI of the same build, the sample models, a tiny database and
short synthetic videos made by the CLI (so that the bindings are checked against it)."""

import csv
import os
import subprocess
import sys

import pytest

SOURCE_DIR = os.environ.get(
    "SILPOSE_SOURCE_DIR", os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
MODELS = os.path.join(SOURCE_DIR, "data", "models")
CLI = os.environ.get("SILPOSE_CLI", os.path.join(SOURCE_DIR, "build", "release", "src", "silpose",
                                                 "cli", "silpose"))

# A tiny database: few views, small renderings, short signatures, two shells.
DB_OPTIONS = {"views": 60, "resolution": 96, "signature_length": 120, "distances": [3.0, 7.0],
              "bins": 4, "threads": 2}
DB_ARGS = ["--views", "60", "--resolution", "96", "--signature-length", "120",
           "--distances", "3,7", "--bins", "4", "--threads", "2"]


def model(name):
    return os.path.join(MODELS, name + ".obj")


# The environment of CLI runs. The CLI carries its own sanitizer runtime in a sanitizer build; the
# one preloaded into Python there (python/CMakeLists.txt) would clash with it, so it is not passed on.
CLI_ENV = {key: value for key, value in os.environ.items() if key != "LD_PRELOAD"}


def run_cli(*args, timeout=900):
    # A run that does not end within `timeout` seconds fails the test, naming the command.
    completed = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True, env=CLI_ENV,
                               timeout=timeout)
    if completed.returncode != 0:
        raise AssertionError(f"silpose {' '.join(map(str, args))} failed:\n{completed.stderr}")
    return completed


def read_poses(path):
    """POSES.csv rows as dicts, without the timing columns (which differ run to run)."""
    with open(path, newline="") as file:
        rows = list(csv.DictReader(file))
    assert rows and "time_ms" in rows[0]
    return [{key: value for key, value in row.items() if not key.startswith("time")}
            for row in rows]


@pytest.fixture(scope="session")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("silpose")


@pytest.fixture(scope="session")
def cli_database(workdir):
    """cow + hand, built by 'silpose build-db'."""
    path = workdir / "cli.db"
    run_cli("build-db", model("cow"), model("hand"), "-o", path, *DB_ARGS)
    return path


def make_video(folder, seed, frames=12):
    """A short colour video of the cow then the hand ('silpose synth --colour --video')."""
    run_cli("synth", model("cow"), model("hand"), "-o", folder, "--trajectory", "walk",
            "--frames", frames, "--switch-every", frames // 2, "--colour", "--video",
            "--camera-noise", 2, "--seed", seed, "--threads", 2)
    return folder


@pytest.fixture(scope="session")
def video(workdir):
    return make_video(workdir / "video", seed=3)


def cli_track(database, sequence, output):
    """'silpose track' of sequence/video.avi with background subtraction."""
    run_cli("track", "-d", database, sequence / "video.avi", "--camera", sequence / "camera.yml",
            "--segment", "bgsub", "--background", sequence / "background.png", "-o", output)
    return output
