# Type stubs of silpose.dask (hand-written; python/tests/test_stubs.py checks them).
import os
from typing import Any, Sequence

from silpose import ViewDatabase

def build_database(mesh_paths: Sequence[str | os.PathLike[str]], out: str | os.PathLike[str],
                   client: Any, **options: object) -> ViewDatabase: ...
def track_videos(videos: Sequence[str | os.PathLike[str]],
                 database: ViewDatabase | str | os.PathLike[str], outdir: str | os.PathLike[str],
                 client: Any, camera: str | os.PathLike[str] | None = None, max_frames: int = 0,
                 **options: object) -> list[dict[str, object]]: ...
