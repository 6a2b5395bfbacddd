//! Which polygon lies across each polygon's edge: meshes share their edges, and a walk
//! from triangle to triangle across them finds the one a ray meets near a known one.

use crate::Polygon;
use rad_core::{PolygonId, NO_POLYGON};
use std::collections::HashMap;

/// For every polygon edge k (from vertex k to vertex k + 1), the polygon across it: the
/// one other polygon with an edge between the same two points (bit for bit) whose normal
/// points the same way (positive dot product), or [`NO_POLYGON`] where there is none or
/// more than one (a border, a crease shared by several sheets, a polygon's own back).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EdgeNeighbours {
    /// Polygon p's edges are `across[start[p]..start[p + 1]]`.
    start: Vec<u32>,
    across: Vec<PolygonId>,
}

impl EdgeNeighbours {
    /// The neighbours of `polygons`' edges.
    pub fn of(polygons: &[Polygon]) -> EdgeNeighbours {
        let key = |v: glam::Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
        let mut start = Vec::with_capacity(polygons.len() + 1);
        start.push(0u32);
        for p in polygons {
            start.push(start.last().copied().unwrap_or(0) + p.vertices().len() as u32);
        }
        // Edges by their end points (the lower first), in polygon and edge order.
        let mut by_edge: HashMap<([u32; 3], [u32; 3]), Vec<(PolygonId, u32)>> = HashMap::new();
        for (idx, p) in polygons.iter().enumerate() {
            let vs = p.vertices();
            for k in 0..vs.len() {
                let (a, b) = (key(vs[k]), key(vs[(k + 1) % vs.len()]));
                let edge = if a <= b { (a, b) } else { (b, a) };
                by_edge
                    .entry(edge)
                    .or_default()
                    .push((idx as PolygonId, start[idx] + k as u32));
            }
        }
        let mut across = vec![NO_POLYGON; *start.last().unwrap_or(&0) as usize];
        for sharing in by_edge.values().filter(|s| s.len() > 1) {
            for &(p, slot) in sharing {
                let n = polygons[p as usize].normal();
                let mut others = sharing
                    .iter()
                    .filter(|&&(q, _)| q != p && polygons[q as usize].normal().dot(n) > 0.0);
                if let (Some(&(q, _)), None) = (others.next(), others.next()) {
                    across[slot as usize] = q;
                }
            }
        }
        EdgeNeighbours { start, across }
    }

    /// The polygons across `polygon`'s edges, edge k from vertex k to vertex k + 1
    /// ([`NO_POLYGON`] where none).
    pub fn across(&self, polygon: PolygonId) -> &[PolygonId] {
        let p = polygon as usize;
        &self.across[self.start[p] as usize..self.start[p + 1] as usize]
    }
}
