"""scripts/stretch-models.py: ten stretched copies of each mesh, which silpose reads."""

import os
import subprocess
import sys

from conftest import SOURCE_DIR, model, run_cli

SCRIPT = os.path.join(SOURCE_DIR, "scripts", "stretch-models.py")


def vertices(path):
    with open(path) as f:
        return [tuple(float(v) for v in line.split()[1:4]) for line in f if line.startswith("v ")]


def test_ten_stretched_copies_with_distinct_proportions(tmp_path):
    subprocess.run([sys.executable, SCRIPT, tmp_path, model("cow")], check=True)
    written = sorted(os.listdir(tmp_path))
    assert written == [f"cow_{k}.obj" for k in range(10)]
    original = vertices(model("cow"))
    copies = [vertices(tmp_path / f"cow_{k}.obj") for k in range(10)]
    assert all(len(c) == len(original) for c in copies)
    assert copies[0] == [tuple(round(x, 6) for x in v) for v in original]
    # cow_1 is stretched by 1.6 along x only.
    for (x, y, z), (sx, sy, sz) in zip(original[:50], copies[1][:50]):
        assert abs(sx - 1.6 * x) < 1e-5 and abs(sy - y) < 1e-5 and abs(sz - z) < 1e-5
    # No two stretches are proportional: each copy's axis extents over the original's (its
    # stretch), divided by their mean, differ from any other copy's by >= 0.14 along some axis.
    def extents(points):
        return [max(p[i] for p in points) - min(p[i] for p in points) for i in range(3)]
    base = extents(original)
    stretches = []
    for c in copies:
        stretch = [e / b for e, b in zip(extents(c), base)]
        stretches.append([x * 3 / sum(stretch) for x in stretch])
    for i in range(10):
        for j in range(i + 1, 10):
            assert max(abs(a - b) for a, b in zip(stretches[i], stretches[j])) > 0.14, (i, j)
    # silpose reads them: a small database of two copies.
    run_cli("build-db", tmp_path / "cow_0.obj", tmp_path / "cow_4.obj", "-o", tmp_path / "two.db",
            "--views", "60", "--resolution", "128", "--distances", "3", "--threads", "1")
    assert (tmp_path / "two.db").stat().st_size > 0


def test_a_missing_or_wrong_file_is_one_line_naming_it(tmp_path):
    missing = tmp_path / "nothing.obj"
    result = subprocess.run([sys.executable, SCRIPT, tmp_path / "out", missing],
                            capture_output=True, text=True)
    assert result.returncode == 1
    assert str(missing) in result.stderr and result.stderr.count("\n") == 1
    result = subprocess.run([sys.executable, SCRIPT, tmp_path / "out", model("cow") + ".ply"],
                            capture_output=True, text=True)
    assert result.returncode == 1 and "not an OBJ file" in result.stderr
    assert subprocess.run([sys.executable, SCRIPT], capture_output=True).returncode == 2
