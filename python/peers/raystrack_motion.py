"""coherad and raystrack 2.0 side by side on a moving scene, one thread each.

    pip install "raystrack==2.0.0"
    cargo build --release -p coherad
    python python/peers/raystrack_motion.py bench-scenes/satellite.json \
        bench-scenes/satellite_motion.json --steps 6 --out results/motion_raystrack.json

Both tools get the same polygons (fanned into triangles for raystrack, one
raystrack surface a polygon, its two sides raystrack's front and back
channels) and the same rigid poses, step by step. coherad runs
`viewfactors --motion --by polygon` with its defaults, and reports each step's
time itself (scene loading and file writing excluded). raystrack 2.0 moves the
surfaces with `Scene.update_transform` (its instanced acceleration keeps each
object's hierarchy) and starts a new run each step, as its README says; each
step's time is its `solve` calls, fronts then backs of two-sided polygons (its
`flip_faces` emits from the back), after a warm-up that compiles its kernels.

The matrices are compared entry by entry (every sender polygon and side,
every receiver polygon and side, plus the factor to backs and to nothing);
the report gives the largest and median absolute difference, raystrack's own
standard error of the entry where the difference is largest, and each tool's
error against a reference (coherad at 8 x 8 origins and 360x1440 a patch).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np


def triangles(vertices):
    """A convex polygon's fan of triangles."""
    return [[0, i, i + 1] for i in range(1, len(vertices) - 1)]


def pose_matrix(pose):
    """A motion file's pose (rotate/matrix, about, translate) as a 4x4."""
    if "matrix" in pose:
        r = np.array(pose["matrix"], dtype=np.float64)
    elif "rotate" in pose:
        axis = np.array(pose["rotate"]["axis"], dtype=np.float64)
        axis /= np.linalg.norm(axis)
        a = np.radians(pose["rotate"]["degrees"])
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        r = np.eye(3) + np.sin(a) * k + (1 - np.cos(a)) * k @ k
    else:
        r = np.eye(3)
    about = np.array(pose.get("about", [0, 0, 0]), dtype=np.float64)
    translate = np.array(pose.get("translate", [0, 0, 0]), dtype=np.float64)
    m = np.eye(4)
    m[:3, :3] = r
    m[:3, 3] = about - r @ about + translate
    return m


def run_coherad(binary, scene, motion_path, out_dir, extra=(), threads="1"):
    """coherad's step files and its per-step times in ms (one thread unless asked)."""
    env = dict(os.environ, RAYON_NUM_THREADS=threads)
    cmd = [binary, "viewfactors", scene, "--motion", motion_path, "--out", out_dir + "/",
           "--by", "polygon", *extra]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    times = [float(m.group(1)) for m in re.finditer(r" in ([0-9.]+) ms;", p.stderr)]
    return times, " ".join(cmd)


def coherad_matrix(path, names, sides):
    """Rows by (polygon, side) over columns (polygon, side) + back + escaped."""
    data = json.load(open(path))
    surfaces = data["surfaces"]
    index = {s["name"]: s["id"] for s in surfaces}
    cols = [(n, side) for n in names for side in sides[n]]
    col_of = {(n, side): i for i, (n, side) in enumerate(cols)}
    m = np.zeros((len(cols), len(cols) + 2))
    by_id = {s["id"]: s for s in surfaces}
    for i, (n, side) in enumerate(cols):
        s = by_id[index[n if side == "front" else n + ":back"]]
        for j, f in s["factors"]:
            other = by_id[j]["name"]
            key = (other[:-5], "back") if other.endswith(":back") else (other, "front")
            m[i, col_of[key]] += f
        m[i, -2] = s["back"]
        m[i, -1] = s["escaped"]
    return m, cols


# The reference: 64 hemispheres a patch at four times the cells. On the
# satellite at rest its largest entry moved by 1.2e-4 from 4 x 4 origins to
# 8 x 8; the figures say so beside each error.
REFERENCE = ("--origins", "8", "--resolution", "360x1440")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("motion")
    ap.add_argument("--steps", type=int, default=None, help="the first N steps only")
    ap.add_argument("--coherad", default="target/release/coherad")
    ap.add_argument("--tolerance", type=float, default=1e-4,
                    help="raystrack's target standard error per entry (its default)")
    ap.add_argument("--out", default=None, help="write the figures here (JSON)")
    args = ap.parse_args()
    if os.environ.get("NUMBA_NUM_THREADS") != "1":
        sys.exit("run with NUMBA_NUM_THREADS=1 (one thread each)")
    import raystrack as rs

    scene_desc = json.load(open(args.scene))
    motion = json.load(open(args.motion))
    if args.steps:
        motion["steps"] = motion["steps"][: args.steps]
    polygons = scene_desc["polygons"]
    names = [p["name"] for p in polygons]
    group_of = {p["name"]: p.get("group") for p in polygons}
    sides = {p["name"]: ["front", "back"] if p.get("two_sided") else ["front"] for p in polygons}
    two_sided = [n for n in names if len(sides[n]) == 2]

    with tempfile.TemporaryDirectory() as tmp:
        mpath = os.path.join(tmp, "motion.json")
        json.dump(motion, open(mpath, "w"))
        ours_ms, ours_cmd = run_coherad(args.coherad, args.scene, mpath, os.path.join(tmp, "out"))
        ours = [coherad_matrix(os.path.join(tmp, "out", f"step_{k:04d}.json"), names, sides)[0]
                for k in range(len(motion["steps"]))]
        print("the reference: coherad at 8 x 8 origins, 360x1440, both threads", file=sys.stderr)
        run_coherad(args.coherad, args.scene, mpath, os.path.join(tmp, "ref"),
                    REFERENCE, threads=str(os.cpu_count()))
        ref = [coherad_matrix(os.path.join(tmp, "ref", f"step_{k:04d}.json"), names, sides)[0]
               for k in range(len(motion["steps"]))]

    meshes = {p["name"]: rs.Mesh(np.array(p["vertices"], np.float32),
                                 np.array(triangles(p["vertices"]), np.int32))
              for p in polygons}
    scene = rs.Scene.from_meshes(meshes)
    options = rs.SolveOptions(accuracy=rs.Accuracy(tolerance=args.tolerance))
    flipped = rs.SolveOptions(sampling=rs.Sampling(flip_faces=True),
                              accuracy=rs.Accuracy(tolerance=args.tolerance))
    rows = []
    with rs.Solver(scene, device="cpu", acceleration="instanced", auto_tune=False) as solver:
        t = time.perf_counter()
        solver.warmup(rs.Query.matrix(), options)
        warmup_s = time.perf_counter() - t
        for k, step in enumerate(motion["steps"]):
            for n in names:
                g = group_of[n]
                pose = step["groups"].get(g) if g is not None else None
                scene.update_transform(n, pose_matrix(pose) if pose else np.eye(4))
            t = time.perf_counter()
            front = solver.solve(rs.Query.matrix(), options)
            back = solver.solve(rs.Query.matrix(senders=two_sided), flipped)
            took = time.perf_counter() - t
            cols = [(n, side) for n in names for side in sides[n]]
            theirs = np.zeros((len(cols), len(cols) + 2))
            error = np.zeros_like(theirs)
            for i, (n, side) in enumerate(cols):
                res = front if side == "front" else back
                for j, (o, oside) in enumerate(cols):
                    c = rs.Channel("surface", o, oside)
                    theirs[i, j] = res.value(n, c) or 0.0
                    error[i, j] = res.error(n, c) or 0.0
                # A one-sided receiver met from behind: coherad's "back".
                for o in names:
                    if len(sides[o]) == 1:
                        theirs[i, -2] += res.value(n, rs.Channel("surface", o, "back")) or 0.0
                theirs[i, -1] = res.value(n, rs.Channel("rest")) or 0.0
            ours_err = np.abs(ours[k] - ref[k])
            theirs_err = np.abs(theirs - ref[k])
            d = np.abs(theirs - ours[k])
            worst = np.unravel_index(np.argmax(d), d.shape)
            rays = int(front.rays_used or 0) + int(back.rays_used or 0)
            rows.append({
                "step": k,
                "name": step.get("name", str(k)),
                "coherad_ms": ours_ms[k],
                "raystrack_ms": took * 1e3,
                "raystrack_rays": rays,
                "raystrack_converged": bool(front.converged and back.converged),
                "max_abs_difference": float(d.max()),
                "median_abs_difference": float(np.median(d[(theirs > 0) | (ours[k] > 0)])),
                "raystrack_stderr_at_max": float(error[worst]),
                "coherad_error": {"max": float(ours_err.max()),
                                  "median": float(np.median(ours_err[ref[k] > 0]))},
                "raystrack_error": {"max": float(theirs_err.max()),
                                    "median": float(np.median(theirs_err[ref[k] > 0]))},
                "at_max": {"from": "%s (%s)" % cols[worst[0]],
                           "to": ("%s (%s)" % cols[worst[1]]) if worst[1] < len(cols)
                           else ["back", "nothing"][worst[1] - len(cols)],
                           "coherad": float(ours[k][worst]), "raystrack": float(theirs[worst])},
            })
            r = rows[-1]
            print(f"step {k}: coherad {r['coherad_ms']:.1f} ms, raystrack {r['raystrack_ms']:.1f} ms "
                  f"({rays} rays), |difference| max {r['max_abs_difference']:.2e} "
                  f"median {r['median_abs_difference']:.2e}; error max coherad "
                  f"{r['coherad_error']['max']:.2e}, raystrack {r['raystrack_error']['max']:.2e}",
                  file=sys.stderr)

    later = rows[1:] or rows
    summary = {
        "scene": args.scene,
        "motion": args.motion,
        "steps": len(rows),
        "coherad_command": ours_cmd.replace(tmp, "TMP"),
        "reference": "coherad " + " ".join(REFERENCE),
        "raystrack": {"version": rs.__version__ if hasattr(rs, "__version__") else "2.0.0",
                      "device": "cpu", "acceleration": "instanced",
                      "tolerance": args.tolerance, "warmup_s": warmup_s},
        "threads": 1,
        "median_ms_after_first": {
            "coherad": float(np.median([r["coherad_ms"] for r in later])),
            "raystrack": float(np.median([r["raystrack_ms"] for r in later])),
        },
        "rows": rows,
    }
    text = json.dumps(summary, indent=1)
    if args.out:
        with open(args.out + ".tmp", "w") as f:
            f.write(text + "\n")
        os.replace(args.out + ".tmp", args.out)
    else:
        print(text)


if __name__ == "__main__":
    main()
