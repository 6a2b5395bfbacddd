"""coherad's radiosity against an independent path tracer (python/reference/pathtrace.py:
random walks through Embree, no coherad code): a closed white cube lit by a small
emitting box hanging under its ceiling, polygon by polygon."""

import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("embreex")

ROOT = pathlib.Path(__file__).resolve().parents[2]
CUBE = ROOT / "bench-scenes" / "cube.json"
BIN = os.environ.get("COHERAD_BIN", str(ROOT / "target" / "release" / "coherad"))
sys.path.insert(0, str(ROOT / "python" / "reference"))

import pathtrace  # noqa: E402


def box_faces(lo, hi):
    """The six faces of an axis-aligned box, each facing out (coherad's normal:
    (v1 - v0) x (v_last - v0))."""
    faces = []
    for axis in range(3):
        a, b = [i for i in range(3) if i != axis]
        for side, sign in ((lo, -1.0), (hi, 1.0)):
            quad = []
            for ua, ub in ((0, 0), (1, 0), (1, 1), (0, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis] = side[axis]
                p[a] = (lo, hi)[ua][a]
                p[b] = (lo, hi)[ub][b]
                quad.append(p)
            v = np.array(quad)
            if np.cross(v[1] - v[0], v[3] - v[0])[axis] * sign < 0:
                quad.reverse()
            faces.append((f"lamp {'xyz'[axis]}{'-+'[sign > 0]}", quad))
    return faces


def lit_cube(path):
    d = json.loads(CUBE.read_text())
    d["materials"] = [
        {"name": "white", "reflectance": [0.5, 0.6, 0.7], "emission": [0.0, 0.0, 0.0]},
        {"name": "lamp", "reflectance": [0.8, 0.8, 0.8], "emission": [40.0, 38.0, 33.0]},
    ]
    for name, quad in box_faces([0.35, 0.85, 0.45], [0.65, 0.9, 0.55]):
        d["polygons"].append({"name": name, "material": "lamp", "vertices": quad,
                              "patches": [4, 4]})
    path.write_text(json.dumps(d))


def test_the_solve_agrees_with_a_path_tracer_polygon_by_polygon(tmp_path):
    scene = tmp_path / "lit_cube.json"
    lit_cube(scene)
    out = tmp_path / "solution.json"
    subprocess.run([BIN, "solve", scene, "--resolution", "180x720", "--out", out, "-q"],
                   check=True)
    sol = json.loads(out.read_text())
    b = np.array(sol["radiosity"])
    ref = pathtrace.trace_polygons(scene, 0.004, seed=1)
    lum = np.array(ref["luminance"])
    err = np.array(ref["luminance_stderr"])
    # Patches are numbered polygon by polygon: the cube's 6 x 100, then the lamp's 6 x 16.
    counts = [100] * 6 + [16] * 6
    poly = np.repeat(np.arange(12), counts)
    ours = np.bincount(poly, b @ pathtrace.LUMINANCE) / counts  # equal patches a polygon
    assert np.all(err / lum < 0.0045), err / lum
    rel = np.abs(ours - lum) / lum
    # Measured: at most 1.0 % (the floor), the reference's standard errors under 0.4 %.
    assert rel.max() < 0.02, rel
    # The reference conserves energy: what the surfaces absorb is what the lamp emits.
    _, _, rho, emit = pathtrace.read_polygons(scene)
    area = np.array(ref["area"])[:, None]
    rgb = np.array(ref["radiosity"])
    absorbed = (area * (rgb - emit) * (1 - rho) / rho).sum(axis=0)
    emitted = (area * emit).sum(axis=0)
    assert np.all(np.abs(absorbed / emitted - 1) < 0.01), absorbed / emitted


def test_the_reference_reads_what_coherad_reads(tmp_path):
    """A vertex where the outline runs straight on (coherad allows it) at v0, where the
    cross product of the edges vanishes: the normal still faces as coherad's; a
    material without "emission" emits nothing; compare.py homes a patch only on a
    polygon of its plane that faces its way."""
    import compare

    square = np.array([[0.5, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 0]], float)
    assert np.array_equal(pathtrace.normal_of(square), [0.0, 0.0, 1.0])
    assert np.array_equal(pathtrace.normal_of(square[::-1]), [0.0, 0.0, -1.0])
    quad = np.array([[0, 0, 0], [2, 0, 0], [2, 0, 3], [0, 0, 3]], float)
    n = np.cross(quad[1] - quad[0], quad[-1] - quad[0])
    assert np.array_equal(pathtrace.normal_of(quad), n / np.linalg.norm(n))

    scene = tmp_path / "plain.json"
    scene.write_text(json.dumps({
        "materials": [{"name": "grey", "reflectance": [0.5, 0.5, 0.5]}],
        "polygons": [{"material": "grey", "vertices": square.tolist()}]}))
    _, vs, rho, emit = pathtrace.read_polygons(scene)
    assert np.array_equal(emit, [[0.0, 0.0, 0.0]]) and np.array_equal(rho, [[0.5] * 3])

    centre = np.array([[0.5, 0.5, 0.0], [0.5, 0.5, 0.0], [0.5, 0.5, 0.5]])
    facing = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0]])
    assert compare.homes(vs, centre, facing).tolist() == [0, -1, -1]
