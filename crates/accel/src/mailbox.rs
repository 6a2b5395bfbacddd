//! Per-thread mailboxes: a polygon is tested at most once per ray.

/// One stamp per polygon; a polygon is "already tested" for the current ray when its
/// stamp equals the ray's. Make one per thread with `RayCast::new_scratch`.
#[derive(Clone, Debug)]
pub struct Mailbox {
    stamps: Vec<u32>,
    ray: u32,
}

impl Mailbox {
    pub fn new(n_polygons: usize) -> Mailbox {
        Mailbox {
            stamps: vec![0; n_polygons],
            ray: 0,
        }
    }

    /// Starts a new ray: every polygon becomes untested.
    #[inline]
    pub fn next_ray(&mut self) {
        self.ray = self.ray.wrapping_add(1);
        if self.ray == 0 {
            self.stamps.fill(0);
            self.ray = 1;
        }
    }

    /// Marks `polygon` tested; returns false if it already was for this ray.
    #[inline]
    pub fn first_visit(&mut self, polygon: u32) -> bool {
        let s = &mut self.stamps[polygon as usize];
        if *s == self.ray {
            false
        } else {
            *s = self.ray;
            true
        }
    }
}
