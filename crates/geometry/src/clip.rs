//! Small 2-D polygon helpers for patch textures: convex clipping, area and centroid.

/// Clips `subject` against the convex, counter-clockwise polygon `clip`
/// (Sutherland–Hodgman). Returns the (possibly empty) clipped polygon.
pub(crate) fn clip_convex(subject: &[[f64; 2]], clip: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut out: Vec<[f64; 2]> = subject.to_vec();
    let n = clip.len();
    for k in 0..n {
        if out.is_empty() {
            break;
        }
        let a = clip[k];
        let b = clip[(k + 1) % n];
        let side = |p: [f64; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        let input = std::mem::take(&mut out);
        for idx in 0..input.len() {
            let cur = input[idx];
            let prev = input[(idx + input.len() - 1) % input.len()];
            let (sc, sp) = (side(cur), side(prev));
            if sc >= 0.0 {
                if sp < 0.0 {
                    out.push(intersect(prev, cur, sp, sc));
                }
                out.push(cur);
            } else if sp >= 0.0 {
                out.push(intersect(prev, cur, sp, sc));
            }
        }
    }
    dedup(out)
}

fn intersect(p: [f64; 2], q: [f64; 2], sp: f64, sq: f64) -> [f64; 2] {
    let t = sp / (sp - sq);
    [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]
}

/// Drops consecutive (near-)duplicate points left by clipping at a vertex.
fn dedup(points: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    let mut out: Vec<[f64; 2]> = Vec::with_capacity(points.len());
    for p in points {
        if out
            .last()
            .is_none_or(|q| (q[0] - p[0]).abs() + (q[1] - p[1]).abs() > 1e-12)
        {
            out.push(p);
        }
    }
    while out.len() > 1 {
        let (f, l) = (out[0], out[out.len() - 1]);
        if (f[0] - l[0]).abs() + (f[1] - l[1]).abs() > 1e-12 {
            break;
        }
        out.pop();
    }
    out
}

/// Signed area (counter-clockwise positive) and centroid of a simple polygon.
pub(crate) fn polygon_area_centroid(points: &[[f64; 2]]) -> (f64, [f64; 2]) {
    if points.len() < 3 {
        return (0.0, points.first().copied().unwrap_or([0.0, 0.0]));
    }
    let (mut a2, mut cx, mut cy) = (0.0, 0.0, 0.0);
    let o = points[0];
    for k in 1..points.len() - 1 {
        let p = [points[k][0] - o[0], points[k][1] - o[1]];
        let q = [points[k + 1][0] - o[0], points[k + 1][1] - o[1]];
        let cross = p[0] * q[1] - p[1] * q[0];
        a2 += cross;
        cx += cross * (p[0] + q[0]);
        cy += cross * (p[1] + q[1]);
    }
    if a2.abs() < 1e-300 {
        return (0.0, o);
    }
    (0.5 * a2, [o[0] + cx / (3.0 * a2), o[1] + cy / (3.0 * a2)])
}

/// Two unit axes spanning the plane of unit normal `normal` (`ex` × `ey` = `normal`):
/// the frame every 2-D clip of coplanar polygons is made in.
pub(crate) fn plane_frame(normal: glam::DVec3) -> (glam::DVec3, glam::DVec3) {
    let helper = if normal.x.abs() < 0.9 {
        glam::DVec3::X
    } else {
        glam::DVec3::Y
    };
    let ex = normal.cross(helper).normalize();
    (ex, normal.cross(ex))
}
