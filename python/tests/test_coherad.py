"""coherad from Python against the coherad binary: the same rows to the last bit, the
same solve, the physics (rows sum to 1 in a closed scene), and errors as exceptions.

The binary is `COHERAD_BIN` (default: target/release/coherad of the repository)."""

import json
import os
import pathlib
import subprocess
import threading

import numpy as np
import pytest
import scipy.sparse

import coherad

ROOT = pathlib.Path(__file__).resolve().parents[2]
CUBE = ROOT / "bench-scenes" / "cube.json"
CORNELL = ROOT / "bench-scenes" / "cornell.json"
BIN = os.environ.get("COHERAD_BIN", str(ROOT / "target" / "release" / "coherad"))


def cli(*args):
    out = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_patches_are_numpy_arrays_of_the_scene():
    scene = coherad.load(CUBE)
    p = scene.patches()
    assert scene.n_patches == 600 and scene.n_polygons == 6
    assert p["center"].shape == (600, 3) and p["center"].dtype == np.float32
    assert p["area"].shape == (600,)
    assert abs(p["area"].sum() - 6.0) < 1e-9
    assert np.allclose(np.linalg.norm(p["normal"], axis=1), 1.0)
    ref = json.loads(cli("patches", CUBE))["patches"]
    assert [q["polygon"] for q in ref] == p["polygon"].tolist()
    assert np.array_equal(np.array([q["center"] for q in ref], dtype=np.float32), p["center"])


def test_the_cubes_rows_equal_the_clis_to_the_last_bit_and_sum_to_one():
    scene = coherad.load(CUBE)
    F = scene.form_factors((45, 180))
    assert isinstance(F, scipy.sparse.csr_matrix) and F.shape == (600, 600)
    rows = json.loads(cli("formfactors", CUBE, "--resolution", "45x180"))["rows"]
    assert len(rows) == 600
    for r in rows:
        i = r["patch"]
        row = F.getrow(i)
        cols, vals = row.indices.tolist(), row.data.tolist()
        assert cols == [e[0] for e in r["entries"]], i
        # Floats from the CLI's JSON (shortest round-trip form) and ours: equal bits.
        assert vals == [e[1] for e in r["entries"]], i
    sums = np.asarray(F.sum(axis=1)).ravel()
    assert np.all(np.abs(sums - 1.0) < 1e-9), np.abs(sums - 1.0).max()
    # A subset of rows, through another caster: the same rows.
    sub = scene.form_factors((45, 180), patches=[5, 17, 599], caster="grid")
    assert (sub != F[[5, 17, 599]]).nnz == 0


def test_a_python_solve_equals_coherad_solve(tmp_path):
    scene = coherad.load(CORNELL)
    b, report = scene.solve((30, 120), with_report=True)
    assert report["converged"] and b.shape == (scene.n_patches, 3)
    out = tmp_path / "s.json"
    cli("--quiet", "solve", CORNELL, "--resolution", "30x120", "--out", out)
    ref = np.array(json.loads(out.read_text())["radiosity"])
    assert np.array_equal(ref, b)
    assert json.loads(out.read_text())["scene_hash"] == scene.scene_hash
    # Jacobi (the solve MPI ranks share by rows): the CLI's file to the bit, and
    # Gauss-Seidel's radiosities within the tolerance.
    bj, rj = scene.solve((30, 120), solver="jacobi", with_report=True)
    assert rj["converged"]
    cli("--quiet", "solve", CORNELL, "--resolution", "30x120", "--solver", "jacobi",
        "--out", out)
    assert np.array_equal(np.array(json.loads(out.read_text())["radiosity"]), bj)
    assert np.abs(bj - b).max() <= 1e-8 * b.max()


def test_view_factors_of_the_cube_closed():
    scene = coherad.load(CUBE)
    names, vf, area, report = scene.view_factors(by="polygon", enclosure="closed",
                                                 resolution=(45, 180), with_report=True)
    assert len(names) == 6 and vf.shape == (6, 6)
    assert np.allclose(vf.sum(axis=1), 1.0, atol=1e-12)
    assert np.allclose(area[:, None] * vf, (area[:, None] * vf).T, atol=1e-12)
    # Unit cube: a face sees each of its 4 neighbours with 0.20004 and the opposite
    # face with 0.19982 (closed forms).
    assert np.all(np.abs(vf[vf > 0] - 0.2) < 1e-3)
    assert report["max_row_sum_error"] < 1e-12


def test_view_factors_over_a_motion_are_the_binarys(tmp_path):
    sat = ROOT / "bench-scenes" / "satellite.json"
    motion = tmp_path / "m.json"
    turn = lambda d: {"rotate": {"axis": [1, 0, 0], "degrees": d}}
    motion.write_text(json.dumps({"steps": [
        {"name": str(k), "groups": {"array +x": turn(15 * k), "array -x": turn(15 * k)}}
        for k in range(3)]}))
    steps = coherad.load(sat).view_factors(by="group", resolution=(20, 80), motion=motion)
    assert len(steps) == 3
    out = tmp_path / "steps"
    cli("viewfactors", sat, "--by", "group", "--resolution", "20x80", "--motion", motion,
        "--out", out)
    for k, (names, vf) in enumerate(steps):
        assert vf.shape == (len(names), len(names))
        surfaces = json.loads((out / f"step_{k:04}.json").read_text())["surfaces"]
        assert [s["name"] for s in surfaces] == names
        for s in surfaces:
            for j, f in s["factors"]:
                assert vf[s["id"], j] == f
    assert not np.array_equal(steps[0][1], steps[2][1])
    with pytest.raises(coherad.CoheradError, match="moves group"):
        motion.write_text('{"steps": [{"groups": {"boom": {}}}]}')
        coherad.load(sat).view_factors(motion=motion)


def test_solves_over_a_motion_are_the_binarys(tmp_path):
    room = ROOT / "bench-scenes" / "room_cart.json"
    motion = tmp_path / "m.json"
    motion.write_text(json.dumps({"keyframes": [
        {"time": 0, "groups": {"cart": {}}},
        {"time": 2, "groups": {"cart": {"translate": [0.5, 0, 0]}}}], "times": [0, 1, 2]}))
    steps = coherad.load(room).solve(resolution=(20, 80), motion=motion, with_report=True)
    assert len(steps) == 3
    out = tmp_path / "steps"
    cli("solve", room, "--resolution", "20x80", "--motion", motion, "--out", out)
    for k, (b, report) in enumerate(steps):
        assert report["converged"]
        solved = json.loads((out / f"step_{k:04}.json").read_text())
        assert np.array_equal(b, np.array(solved["radiosity"]))
    # (Warm from the step before: fewer sweeps than the first step's.)
    assert steps[1][1]["iterations"] < steps[0][1]["iterations"]
    assert not np.array_equal(steps[0][0], steps[2][0])
    with pytest.raises(coherad.CoheradError, match="exact rows"):
        coherad.load(room).solve(resolution=(8, 32), method="estimated", motion=motion)


def test_errors_are_exceptions_with_the_clis_messages(tmp_path):
    with pytest.raises(coherad.CoheradError, match="no/such/file.json"):
        coherad.load("/no/such/file.json")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nf 1 2 3 4 5 6\n")
    with pytest.raises(coherad.CoheradError, match="--triangulate"):
        coherad.load(bad, patch_size=0.5)
    mended = coherad.load(bad, patch_size=0.5, triangulate=True)
    assert mended.n_polygons == 4 and any("split 1" in n for n in mended.notes)
    # A tetrahedron with one face turned over: a warning naming repair, then mended.
    tet = tmp_path / "tet.obj"
    tet.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                   "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 4 3\n")
    assert any("--repair would mend this mesh: 1 face turned over" in n
               for n in coherad.load(tet, patch_size=1).notes)
    mended = coherad.load(tet, patch_size=1, repair=True)
    assert any(n.startswith("repaired: 1 face turned over") for n in mended.notes), mended.notes
    with pytest.raises(coherad.CoheradError, match="--weld"):
        coherad.load(tet, patch_size=1, repair=True, weld=-1)
    scene = coherad.load(CUBE)
    for call, text in [
        (lambda: scene.form_factors((0, 10)), "resolution"),
        (lambda: scene.form_factors((-3, 10)), "resolution"),
        (lambda: scene.form_factors((6, 24), patches=[-1]), "out of range"),
        (lambda: scene.solve((6, 24), solver="progressive", reciprocal=False), "raw rows"),
        (lambda: scene.form_factors((6, 24), method="magic"), "method"),
        (lambda: scene.form_factors((6, 24), patches=[600]), "out of range"),
        (lambda: scene.view_factors(by="room"), "by"),
        (lambda: scene.solve((6, 24), solver="conjugate-gradient"), "solver"),
        # 14,400 patches: over the dense matrix's 10,000 surfaces, refused before any
        # row is made.
        (lambda: coherad.load(ROOT / "bench-scenes" / "loft.json").view_factors(by="patch"),
         "14400 surfaces, over the 10000"),
    ]:
        with pytest.raises(coherad.CoheradError, match=text):
            call()


def test_arrays_are_writable_and_the_error_pickles():
    import pickle
    scene = coherad.load(CUBE)
    F = scene.form_factors((6, 24))
    F.data *= 2.0
    p = scene.patches()
    p["area"][0] = 0.0
    e = pickle.loads(pickle.dumps(coherad.CoheradError("x")))
    assert isinstance(e, coherad.CoheradError)


def test_long_work_releases_the_gil():
    # While a solve runs in another thread, this one keeps running Python.
    scene = coherad.load(CORNELL)
    ticks = []
    t = threading.Thread(target=lambda: scene.solve((60, 240)))
    t.start()
    while t.is_alive():
        ticks.append(1)
        t.join(0.001)
    assert len(ticks) > 3, len(ticks)
