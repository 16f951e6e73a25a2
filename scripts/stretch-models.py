#!/usr/bin/env python3
"""Makes a catalogue of many distinct objects from a few meshes, for measuring silpose at scale.

Each input OBJ is written ten times into OUT_DIR, stretched along its axes by one of ten factor
triples of which no two are proportional (each divided by its mean, any two differ by at least 0.14
along some axis): stretches proportional to each other would give the same silhouettes up to size,
which no silhouette method can tell apart.

    python3 scripts/stretch-models.py OUT_DIR MODEL.obj [MODEL.obj ...]

writes OUT_DIR/<name>_<k>.obj for k = 0..9 (k = 0 is the mesh unchanged). Only vertex positions
change; materials are dropped. docs/PERFORMANCE.md ("Scale") uses it on the 20 reference models.
"""

import os
import sys

STRETCHES = [(1.0, 1.0, 1.0), (1.6, 1.0, 1.0), (1.0, 1.6, 1.0), (1.0, 1.0, 1.6),
             (1.6, 1.6, 1.0), (1.6, 1.0, 1.6), (1.0, 1.6, 1.6), (1.6, 1.3, 1.0),
             (1.0, 1.6, 1.3), (1.3, 1.0, 1.6)]


def main(argv):
    if len(argv) < 3:
        sys.stderr.write(__doc__)
        return 2
    out_dir, models = argv[1], argv[2:]
    os.makedirs(out_dir, exist_ok=True)
    for path in models:
        if not path.lower().endswith('.obj'):
            sys.stderr.write(f'stretch-models.py: {path}: not an OBJ file\n')
            return 1
        try:
            with open(path, encoding='utf-8', errors='replace') as f:
                lines = f.read().splitlines()
        except OSError as error:
            sys.stderr.write(f'stretch-models.py: {path}: {error.strerror}\n')
            return 1
        name = os.path.splitext(os.path.basename(path))[0]
        for k, (sx, sy, sz) in enumerate(STRETCHES):
            out = []
            for line in lines:
                if line.startswith('v '):
                    x, y, z = (float(value) for value in line.split()[1:4])
                    out.append(f'v {x * sx:.6f} {y * sy:.6f} {z * sz:.6f}')
                elif not line.startswith(('mtllib', 'usemtl')):
                    out.append(line)
            with open(os.path.join(out_dir, f'{name}_{k}.obj'), 'w', encoding='utf-8') as f:
                f.write('\n'.join(out) + '\n')
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
