"""coherad from Python: radiosity form factors, surface-to-surface view factors and
radiosity solves by hemisphere ray casting, on scene files of any format the `coherad`
binary reads (JSON, OBJ, View3D .vs3, PLY, STL, glTF/GLB).

    import coherad
    scene = coherad.load("bench-scenes/cube.json")
    p = scene.patches()                       # dict of numpy arrays
    F = scene.form_factors((180, 720))        # scipy.sparse.csr_matrix, n x n
    names, VF = scene.view_factors(by="polygon", enclosure="closed")
    B = scene.solve((180, 720))               # numpy (n, 3) radiosities

Long computations release the GIL and use every core (rayon); results do not depend on
the thread count. Errors raise `coherad.CoheradError` with the binary's messages.
"""

import numpy as np
import scipy.sparse

from . import _native
from ._native import CoheradError

__all__ = ["load", "Scene", "CoheradError", "__version__"]
__version__ = _native.__version__


def _array(raw, dtype, shape=None):
    # A copy in native byte order: writable, and owning its memory.
    a = np.frombuffer(raw, dtype=np.dtype(dtype).newbyteorder("<")).astype(dtype, copy=True)
    return a.reshape(shape) if shape is not None else a


def _resolution(resolution):
    try:
        nt, np_ = (int(r) for r in resolution)
    except (TypeError, ValueError):
        raise CoheradError(f"resolution {resolution!r}: give (n_theta, n_phi), e.g. (180, 720)")
    if not (0 < nt < 2**32 and 0 < np_ < 2**32):
        raise CoheradError(f"resolution {resolution!r}: both counts must be positive")
    return (nt, np_)


class Scene:
    """A loaded, validated scene (see `load`)."""

    def __init__(self, native):
        self._s = native

    @property
    def path(self):
        return self._s.path

    @property
    def scene_hash(self):
        """The fingerprint solution files record (`fnv1a64:...`)."""
        return self._s.scene_hash

    @property
    def n_patches(self):
        return self._s.n_patches

    @property
    def n_polygons(self):
        return self._s.n_polygons

    @property
    def notes(self):
        """What loading warned of (`triangulate`'s splits and drops, clamped values)."""
        return self._s.notes

    def __repr__(self):
        return f"<coherad.Scene {self.path!r}: {self.n_polygons} polygons, {self.n_patches} patches>"

    def patches(self):
        """Every patch: dict of numpy arrays `center` (n, 3) float32, `normal` (n, 3)
        float32, `area` (n,) float64 and `polygon` (n,) uint32."""
        c, n, a, p = self._s.patches_raw()
        k = self.n_patches
        return {
            "center": _array(c, np.float32, (k, 3)),
            "normal": _array(n, np.float32, (k, 3)),
            "area": _array(a, np.float64),
            "polygon": _array(p, np.uint32),
        }

    def form_factors(self, resolution=(180, 720), method="exact", patches=None, caster=None,
                     with_losses=False):
        """Form-factor rows F_ij as a `scipy.sparse.csr_matrix` (one row a patch asked
        for, in that order; all patches by default, so n x n), by hemisphere ray casting
        at `resolution` = (n_theta, n_phi). `method`: "exact", "estimated" (improved),
        "estimated/faithful" or "estimated/improved"; `caster`: "scan", "grid",
        "hierarchy" or "facets" (default: the fastest for the scene; every caster gives the same
        rows, to the bit). With `with_losses`, also (back, escaped): per row, the form
        factor of rays that met a polygon from behind or left the scene."""
        if patches is not None:
            patches = [int(p) for p in patches]
            bad = [p for p in patches if not 0 <= p < self.n_patches]
            if bad:
                raise CoheradError(f"patch {bad[0]} is out of range: the scene has {self.n_patches} patches")
        ids, indptr, cols, vals, back, escaped = self._s.form_factors_raw(
            _resolution(resolution), method, caster, patches)
        ids = _array(ids, np.uint32)
        m = scipy.sparse.csr_matrix(
            (_array(vals, np.float64), _array(cols, np.uint32).astype(np.int64),
             _array(indptr, np.int64)),
            shape=(len(ids), self.n_patches))
        if with_losses:
            return m, (_array(back, np.float64), _array(escaped, np.float64))
        return m

    def view_factors(self, by=None, origins=None, enclosure=None, resolution=(180, 720),
                     caster=None, script_f=None, with_report=False, method=None,
                     tolerance=None, motion=None):
        """Surface-to-surface view factors F_IJ (area to area): (names, numpy (m, m)
        matrix), surfaces by "patch", "polygon" or "group" (default: group for a View3D
        file, else polygon); `origins` N: N x N hemispheres a patch (default 2);
        `enclosure`: "raw", "reciprocal" (A_I F_IJ = A_J F_JI, each row keeping its sum)
        or "closed" (also every row summing to 1; default: a View3D file's encl, else
        raw); `script_f`: Hottel's total exchange factors (default: a View3D file's emit);
        `method`: "auto" (the default: in closed form where no polygon can come between
        two polygons, from hemispheres elsewhere), "exact" or "hemisphere"; `tolerance`:
        the closed-form factors' quadrature tolerance (default 1e-10).
        Up to 10,000 surfaces (a dense matrix); more through `coherad viewfactors
        --format bin`. With `with_report`, also (areas, a dict of the errors before and
        after the rule). With `motion` (a motion file, JSON or a glTF file's animations:
        named groups moved rigidly through steps, as `coherad viewfactors --motion`), a
        list of those, one a step, each step casting again only what the motion can
        change."""
        made = self._s.view_factors_raw(
            by, origins, enclosure, _resolution(resolution), caster, script_f, method,
            tolerance, None if motion is None else str(motion))

        def unpack(names, dense, area, report):
            m = len(names)
            matrix = _array(dense, np.float64, (m, m))
            if with_report:
                return names, matrix, _array(area, np.float64), report
            return names, matrix

        steps = [unpack(*step) for step in made]
        return steps if motion is not None else steps[0]

    def solve(self, resolution=(180, 720), method="auto", caster=None, solver="gauss-seidel",
              tolerance=None, reciprocal=True, with_report=False, motion=None):
        """Radiosity B of every patch (numpy (n, 3)), as `coherad solve` computes it:
        rows at `resolution` by `method` ("auto", as `coherad solve`: estimated on a
        mesh of 20,000 patches or more mostly in flat walls, else exact; "exact",
        "estimated", "estimated/faithful"), made reciprocal (unless `reciprocal=False`), solved by
        "gauss-seidel", "progressive" or "jacobi" to `tolerance`. With `with_report`, also a dict
        (converged, iterations, residual, relative_imbalance, storage). With `motion` (a
        motion file, JSON or a glTF file's animations, as `coherad solve --motion`), a list
        of those, one a step: exact rows, each step's casting again only what the motion
        can change, Gauss-Seidel starting from the step before's radiosities."""
        made = self._s.solve_raw(_resolution(resolution), method, caster, solver,
                                 tolerance, reciprocal, None if motion is None else str(motion))
        steps = []
        for raw, report in made:
            b = _array(raw, np.float64, (self.n_patches, 3))
            steps.append((b, report) if with_report else b)
        return steps if motion is not None else steps[0]


def load(path, patch_size=None, triangulate=False, reflectance=None, materials=None,
         repair=False, weld=None):
    """Loads and validates a scene file (the formats and options of the `coherad`
    binary: `patch_size` for mesh files, `triangulate` for concave and warped faces,
    `reflectance` (one or three values) for faces without a material, `materials` a
    side file of materials and face rules, `repair` to mend a mesh as `--repair` does,
    with `weld` its welding distance). `Scene.notes` says what loading did."""
    if reflectance is not None:
        reflectance = [float(reflectance)] if np.isscalar(reflectance) else [float(r) for r in reflectance]
    return Scene(_native.load(str(path), patch_size, bool(triangulate), reflectance,
                              None if materials is None else str(materials),
                              bool(repair), None if weld is None else float(weld)))
