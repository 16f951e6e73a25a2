"""The examples of README.md's "From Python" section run as written, on files named as there."""

import contextlib
import io
import os
import re
import shutil

from conftest import SOURCE_DIR, model


def readme_examples():
    text = open(os.path.join(SOURCE_DIR, "README.md")).read()
    section = text.split("\n## From Python\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", section, re.S)


def test_readme_examples_run(video, tmp_path, monkeypatch):
    examples = readme_examples()
    assert len(examples) >= 2
    for name in ("cow", "hand"):
        shutil.copy(model(name), tmp_path / f"{name}.obj")
    shutil.copy(video / "video.avi", tmp_path / "recording.avi")
    shutil.copy(video / "camera.yml", tmp_path / "camera.yml")
    shutil.copy(video / "background.png", tmp_path / "empty.png")
    monkeypatch.chdir(tmp_path)
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        for example in examples:
            exec(compile(example, "README.md", "exec"), {})
    lines = printed.getvalue().splitlines()
    # The match example prints the cow's view first; the tracking example one line per frame with
    # a pose, naming the object seen (the video shows the cow, then the hand).
    assert lines[0].startswith("cow 17 ")
    tracked = [line for line in lines if line.split()[0].isdigit()]
    assert len(tracked) >= 8
    assert {line.split()[1] for line in tracked} <= {"cow", "hand"}
    assert os.path.exists("parts.db")
