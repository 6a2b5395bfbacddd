"""Per-polygon mean radiosity of a coherad JSON scene by random walks through Embree.

An independent reference for coherad's solutions: no patches, no hemispheres, no
coherad code. Each sample is a point drawn uniformly on a polygon; its radiosity
B(x) = E(x) + rho(x) * (integral over the hemisphere of B seen, cos / pi) is estimated by
a random walk: cosine-weighted bounces, next-event estimation on the emitting polygons
(a point on them by area) weighted against the bounces by the balance heuristic, and
Russian roulette. Rays go through Embree (the `embreex` package). Back faces and rays
that escape are black, as in coherad. Each polygon is sampled until the standard error
of its mean luminance is at most TARGET of the mean (or 4,000,000 samples).

    python pathtrace.py SCENE.json TARGET SEED OUT.json [FIRST:LAST]

FIRST:LAST traces only those polygons (for running parts in parallel; merge.py joins
them). OUT.json holds, per polygon, the mean RGB radiosity, its luminance, the standard
error of that, the samples and the area. The same arguments give the same file.
"""

import json
import os
import sys
import time

import numpy as np
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
BATCH = 4096
MIN_SAMPLES = 16 * BATCH
MAX_SAMPLES = 4_000_000


def read_polygons(path):
    """A coherad JSON scene's polygons: (the document, each polygon's vertices as an
    array, reflectances, emissions), vertices given inline or by "indices" into the
    document's shared "vertices"; a material without "emission" emits nothing, as in
    coherad. (An "obstruction" polygon is a surface like any other here, as in
    `coherad solve`: the flag only keeps it out of view-factor matrices.)"""
    d = json.load(open(path))
    mats = {m["name"]: m for m in d["materials"]}
    shared = np.array(d.get("vertices", []), dtype=np.float64)
    vs = [np.array(p["vertices"], dtype=np.float64) if "vertices" in p
          else shared[p["indices"]] for p in d["polygons"]]
    rho = np.array([mats[p["material"]]["reflectance"] for p in d["polygons"]], float)
    emit = np.array([mats[p["material"]].get("emission", [0.0, 0.0, 0.0])
                     for p in d["polygons"]], float)
    return d, vs, rho, emit


def normal_of(v):
    """A convex polygon's unit normal, facing as coherad's e_u x e_v (u along v0 -> v1,
    v along v0 -> last): that cross product where its two edges are far from parallel,
    else Newell's sum over every edge (coherad allows collinear vertices, which make
    the cross product at v0 vanish), which faces the same way."""
    e_u, e_v = v[1] - v[0], v[-1] - v[0]
    n = np.cross(e_u, e_v)
    if np.linalg.norm(n) <= 1e-6 * np.linalg.norm(e_u) * np.linalg.norm(e_v):
        n = np.cross(v, np.roll(v, -1, axis=0)).sum(axis=0)
    return n / np.linalg.norm(n)


class Scene:
    """A JSON scene's polygons as Embree triangles, with what the walks read."""

    def __init__(self, path):
        d, vs, self.rho, self.emit = read_polygons(path)
        tris, owner, tri_area = [], [], []
        n = len(vs)
        self.normal, self.area = np.zeros((n, 3)), np.zeros(n)
        for k, (p, v) in enumerate(zip(d["polygons"], vs)):
            if p.get("two_sided"):
                raise SystemExit(f"polygon {k}: two-sided polygons are not handled here")
            self.normal[k] = normal_of(v)
            for i in range(1, len(v) - 1):
                t = np.array([v[0], v[i], v[i + 1]])
                a = 0.5 * np.linalg.norm(np.cross(t[1] - t[0], t[2] - t[0]))
                tris.append(t), owner.append(k), tri_area.append(a)
                self.area[k] += a
        self.tris = np.array(tris, dtype=np.float32)
        self.owner, self.tri_area = np.array(owner), np.array(tri_area)
        self.tri_of = [np.nonzero(self.owner == k)[0] for k in range(n)]
        # Each polygon's triangles by area, for its sample points.
        self.tri_cdf = [np.cumsum(self.tri_area[t]) / self.tri_area[t].sum()
                        for t in self.tri_of]
        self.eps = 1e-6 * float(np.abs(self.tris).max())
        self.embree = rtcs.EmbreeScene()
        TriangleMesh(self.embree, self.tris)
        self.is_light = self.emit.max(axis=1) > 0
        lights = np.nonzero(self.is_light)[0]
        if len(lights) == 0:
            raise SystemExit("the scene emits nothing")
        self.light_tris = np.concatenate([self.tri_of[k] for k in lights])
        cdf = np.cumsum(self.tri_area[self.light_tris])
        self.light_area = cdf[-1]
        self.light_cdf = cdf / cdf[-1]

    def trace(self, o, d, far=None):
        res = self.embree.run(o.astype(np.float32), d.astype(np.float32),
                              dists=None if far is None else far.astype(np.float32),
                              output=1)
        return res["primID"], res["tfar"].astype(np.float64)


class Walks:
    """Random walks from points of one polygon: their radiosity samples."""

    def __init__(self, scene, rng):
        self.s, self.rng = scene, rng

    def points_on(self, tri_ids):
        t = self.s.tris[tri_ids].astype(np.float64)
        r1, r2 = self.rng.random(len(tri_ids)), self.rng.random(len(tri_ids))
        s = np.sqrt(r1)
        return (t[:, 0] * (1 - s)[:, None] + t[:, 1] * (s * (1 - r2))[:, None]
                + t[:, 2] * (s * r2)[:, None])

    def cosine_dirs(self, nrm):
        m = len(nrm)
        r1, r2 = self.rng.random(m), self.rng.random(m)
        phi, sr = 2 * np.pi * r1, np.sqrt(r2)
        a = np.where(np.abs(nrm[:, 0:1]) > 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
        t = np.cross(nrm, a)
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        b = np.cross(nrm, t)
        return ((sr * np.cos(phi))[:, None] * t + (sr * np.sin(phi))[:, None] * b
                + np.sqrt(1 - r2)[:, None] * nrm)

    def direct(self, x, nrm, thr):
        """Light sampled on the emitters, weighted against the bounces; the term
        E (cos_x / pi) / (p_l + p_b) is at most E."""
        s = self.s
        lt = s.light_tris[np.searchsorted(s.light_cdf, self.rng.random(len(x)))]
        y = self.points_on(lt)
        w = y - x
        r = np.linalg.norm(w, axis=1)
        om = w / r[:, None]
        ny = s.normal[s.owner[lt]]
        cx, cy = np.einsum("ij,ij->i", nrm, om), -np.einsum("ij,ij->i", ny, om)
        i = np.nonzero((cx > 0) & (cy > 0))[0]
        out = np.zeros((len(x), 3))
        if len(i) == 0:
            return out
        # Visibility between the two points each lifted off its surface by eps: the
        # segment stays in front of both planes, so it meets neither surface itself,
        # however grazing.
        o = x[i] + s.eps * nrm[i]
        seg = y[i] + s.eps * ny[i] - o
        length = np.linalg.norm(seg, axis=1)
        pid, _ = s.trace(o, seg / length[:, None], length * (1 - 1e-6))
        i = i[pid < 0]
        p_l = r[i] ** 2 / (cy[i] * s.light_area)
        p_b = cx[i] / np.pi
        out[i] = thr[i] * s.emit[s.owner[lt[i]]] * (p_b / (p_l + p_b))[:, None]
        return out

    def samples(self, k, m):
        """m radiosity samples (RGB) at points drawn uniformly on polygon k."""
        s = self.s
        pick = np.searchsorted(s.tri_cdf[k], self.rng.random(m))
        # (The cumulative sum may end an ulp below 1.)
        x = self.points_on(s.tri_of[k][np.minimum(pick, len(s.tri_of[k]) - 1)])
        nx = np.repeat(s.normal[k][None], m, axis=0)
        value = np.repeat(s.emit[k][None], m, axis=0)
        thr = np.repeat(s.rho[k][None], m, axis=0)
        alive, depth = np.arange(m), 0
        while len(alive):
            xa, na, ta_ = x[alive], nx[alive], thr[alive]
            value[alive] += self.direct(xa, na, ta_)
            d = self.cosine_dirs(na)
            o = xa + s.eps * na
            pid, tf = s.trace(o, d)
            q = s.owner[np.maximum(pid, 0)]
            cos_q = -np.einsum("ij,ij->i", d, s.normal[q])
            keep = (pid >= 0) & (cos_q > 0)
            lit = np.nonzero(keep & s.is_light[q])[0]
            if len(lit):
                p_b = np.einsum("ij,ij->i", d[lit], na[lit]) / np.pi
                p_l = tf[lit] ** 2 / (cos_q[lit] * s.light_area)
                value[alive[lit]] += (ta_[lit] * s.emit[q[lit]]
                                      * (p_b / (p_l + p_b))[:, None])
            newthr = ta_ * s.rho[q]
            depth += 1
            if depth >= 2:
                p = np.minimum(0.95, newthr.max(axis=1) / np.maximum(ta_.max(axis=1), 1e-300))
                keep &= self.rng.random(len(alive)) < p
                newthr /= np.maximum(p, 1e-300)[:, None]
            idx = np.nonzero(keep)[0]
            a = alive[idx]
            x[a] = o[idx] + tf[idx, None] * d[idx]
            nx[a], thr[a] = s.normal[q[idx]], newthr[idx]
            alive = a
        return value


def trace_polygons(path, target, seed, first=0, last=None, progress=None):
    """The per-polygon means of polygons first..last as a dict (what OUT.json holds)."""
    scene = Scene(path)
    n = len(scene.area)
    last = n if last is None else last
    walks = Walks(scene, np.random.default_rng(seed))
    sums, lsum, sq = np.zeros((n, 3)), np.zeros(n), np.zeros(n)
    count = np.zeros(n, dtype=np.int64)
    start = time.time()

    def rel_err(k):
        if count[k] < MIN_SAMPLES:
            return np.inf
        mu = lsum[k] / count[k]
        var = max(sq[k] / count[k] - mu ** 2, 0.0)
        return np.sqrt(var / count[k]) / max(mu, 1e-300)

    for k in range(first, last):
        while rel_err(k) > target and count[k] < MAX_SAMPLES:
            v = walks.samples(k, BATCH)
            lum = v @ LUMINANCE
            sums[k] += v.sum(axis=0)
            lsum[k] += lum.sum()
            sq[k] += (lum ** 2).sum()
            count[k] += BATCH
        if progress:
            progress(k, time.time() - start)
    c = np.maximum(count, 1)
    mean = sums / c[:, None]
    lum = lsum / c
    stderr = np.sqrt(np.maximum(sq / c - lum ** 2, 0) / c)
    return {"scene": str(path), "target_relative_stderr": target, "seed": seed,
            "polygons": [first, last], "samples": count.tolist(),
            "radiosity": mean.tolist(), "luminance": lum.tolist(),
            "luminance_stderr": stderr.tolist(), "area": scene.area.tolist()}


def main():
    if len(sys.argv) not in (5, 6):
        raise SystemExit(__doc__)
    path, target, seed, out = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    first, last = (int(a) for a in sys.argv[5].split(":")) if len(sys.argv) == 6 else (0, None)

    def progress(k, seconds):
        if k % 20 == 0:
            print(f"polygon {k}, {seconds:.0f} s", file=sys.stderr, flush=True)

    result = trace_polygons(path, target, seed, first, last, progress)
    tmp = out + ".part"
    json.dump(result, open(tmp, "w"))
    os.replace(tmp, out)


if __name__ == "__main__":
    main()
