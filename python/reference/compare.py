"""coherad solutions against the path-traced reference, polygon by polygon.

    python compare.py SCENE.json REF.json[,REF2.json...] [SOLVED.json SOLUTION.json LABEL]...

SCENE.json is the scene the reference traced (its polygons are the ones compared);
REF.json the output of pathtrace.py (parts over ranges of polygons joined with commas).
Each SOLVED.json / SOLUTION.json pair is a coherad scene of the same geometry (the same
scene, or one cut finer: each patch goes to the polygon of SCENE.json that holds its
centre, in the same plane and facing the same way) and its `coherad solve` output; its
area-weighted mean luminance per polygon, of B + rho * ambient as a render shows it, is
compared with the reference's. Prints, per solution: the median and largest relative
difference, the polygons over 2 % (and their share of the area), and how many of those
are over 3 standard errors of the reference; then each pair of solutions. JSON scenes
with parallelogram and triangle polygons only.
"""

import json
import sys

import numpy as np

from pathtrace import LUMINANCE, normal_of, read_polygons


def reference(paths):
    """The parts of a path-traced reference joined: each covers its range of polygons."""
    parts = [json.load(open(p)) for p in paths.split(",")]
    n = len(parts[0]["area"])
    out = {"area": np.array(parts[0]["area"])}
    for key in ("luminance", "luminance_stderr", "samples"):
        out[key] = np.full(n, np.nan)
        for p in parts:
            a, b = p["polygons"]
            out[key][a:b] = p[key][a:b]
    if np.isnan(out["luminance"]).any():
        raise SystemExit(f"the reference parts leave polygons untraced: {paths}")
    return out


def polygons(path):
    d, vs, rho, _ = read_polygons(path)
    return d, vs, rho


def patches(scene_path, solution_path):
    """Centre, normal, area and shown luminance of every patch, in coherad's patch
    order."""
    d, vs, rhos = polygons(scene_path)
    sol = json.load(open(solution_path))
    b = np.array(sol["radiosity"], float)
    ambient = np.array(sol.get("ambient", [0, 0, 0]), float)
    centre, normal, area, rho = [], [], [], []
    for k, (p, v, r) in enumerate(zip(d["polygons"], vs, rhos)):
        nu, nv = p.get("patches", [1, 1])
        e_u, e_v = v[1] - v[0], v[-1] - v[0]
        whole = np.linalg.norm(np.cross(e_u, e_v))
        n = normal_of(v)
        if len(v) == 3 and nu == nv == 1:
            centre.append(v.mean(axis=0)), area.append(whole / 2), rho.append(r)
            normal.append(n)
            continue
        if len(v) != 4 or not np.allclose(v[2], v[1] + e_v):
            raise SystemExit(f"{scene_path}: polygon {k} is not a parallelogram or a one-patch triangle")
        for j in range(nv):
            for i in range(nu):
                centre.append(v[0] + (i + 0.5) / nu * e_u + (j + 0.5) / nv * e_v)
                area.append(whole / (nu * nv)), rho.append(r), normal.append(n)
    if len(centre) != len(b):
        raise SystemExit(f"{solution_path}: {len(b)} radiosities for {len(centre)} patches")
    shown = (b + np.array(rho) * ambient) @ LUMINANCE
    return np.array(centre), np.array(normal), np.array(area), shown


def homes(vs, centre, normal):
    """The polygon of vs holding each centre (in its plane, strictly inside every edge,
    facing the same way as the patch's `normal`), or -1. Any convex polygon."""
    out = np.full(len(centre), -1)
    scale = max(np.abs(v).max() for v in vs)
    for k, v in enumerate(vs):
        n = normal_of(v)
        inside = (np.abs((centre - v[0]) @ n) <= 1e-4 * scale) & (normal @ n > 0) & (out < 0)
        for a, b in zip(v, np.roll(v, -1, axis=0)):
            inside &= np.cross(b - a, centre - a) @ n > 0
        out[inside] = k
    return out


def means(scene, vs, solved, solution):
    centre, normal, area, lum = patches(solved, solution)
    h = homes(vs, centre, normal)
    if (h < 0).any():
        raise SystemExit(f"{solved}: {(h < 0).sum()} patches lie on no polygon of {scene}")
    return np.bincount(h, area * lum, len(vs)) / np.bincount(h, area, len(vs))


def main():
    if len(sys.argv) < 3 or (len(sys.argv) - 3) % 3:
        raise SystemExit(__doc__)
    scene, ref = sys.argv[1], reference(sys.argv[2])
    _, vs, _ = polygons(scene)
    lum, err, area = ref["luminance"], ref["luminance_stderr"], ref["area"]
    print(f"reference: {len(lum)} polygons, relative standard error median "
          f"{np.median(err / lum) * 100:.2f} %, largest {np.max(err / lum) * 100:.2f} %")
    rest, found = sys.argv[3:], {}
    for i in range(0, len(rest), 3):
        solved, solution, label = rest[i:i + 3]
        m = found[label] = means(scene, vs, solved, solution)
        rel = np.abs(m - lum) / lum
        over = rel > 0.02
        print(f"{label}: median {np.median(rel) * 100:.2f} %, over 2 %: {over.sum()} "
              f"({area[over].sum() / area.sum() * 100:.1f} % of the area), of which over "
              f"3 standard errors {(over & (np.abs(m - lum) > 3 * err)).sum()}; worst "
              f"{rel.max() * 100:.1f} % (polygon {rel.argmax()}: {m[rel.argmax()]:.4g} "
              f"against {lum[rel.argmax()]:.4g})")
    labels = list(found)
    for x, a in enumerate(labels):
        for b in labels[x + 1:]:
            rel = np.abs(found[b] - found[a]) / found[a]
            print(f"{b} against {a}: median {np.median(rel) * 100:.2f} %, over 2 %: "
                  f"{(rel > 0.02).sum()}")


if __name__ == "__main__":
    main()
