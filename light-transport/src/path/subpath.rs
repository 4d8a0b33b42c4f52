//! A subpath's vertices in storage kept from one walk to the next (Veach 1997 §10.2's camera and
//! light subpaths). A vertex is large (its BSDF holds its lobes inline), so a walk that pushed a
//! fresh vertex per bounce copied it into place, and its BSDF once more; here a cleared subpath
//! keeps its vertices, and a walk overwrites them field by field, rebuilding each BSDF where the
//! previous walk left one.

use super::vertex::Vertex;
use crate::geometry::SurfacePoint;
use crate::math::DVec3;
use crate::spectrum::Rgb;
use std::ops::{Deref, DerefMut};

/// The vertices of a camera or light subpath, read as a slice (`&subpath[i]`, `subpath.len()`);
/// [`Subpath::clear`] keeps their storage for the next walk.
#[derive(Clone, Debug, Default)]
pub struct Subpath {
    /// Every vertex slot ever used; the first `len` are the subpath.
    slots: Vec<Vertex>,
    len: usize,
}

impl Subpath {
    /// An empty subpath.
    pub const fn new() -> Self {
        Self {
            slots: Vec::new(),
            len: 0,
        }
    }

    /// Empty the subpath, keeping its vertices' storage.
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Make room for `n` vertices in all (one allocation: growing moves every vertex).
    pub fn reserve(&mut self, n: usize) {
        self.slots.reserve(n.saturating_sub(self.slots.len()));
    }

    /// Append `v`.
    pub fn push(&mut self, v: Vertex) {
        if let Some(slot) = self.slots.get_mut(self.len) {
            *slot = v;
        } else {
            self.slots.push(v);
        }
        self.len += 1;
    }

    /// Append a surface vertex at `point`, arrived at from `wo` with throughput `beta` (densities
    /// 0, not delta), and return it. Its BSDF is whatever the slot held last, or none: the caller
    /// rebuilds it ([`crate::scene::Scene::bsdf_into`]) before anything reads it.
    pub fn push_surface(&mut self, point: &SurfacePoint, wo: DVec3, beta: Rgb) -> &mut Vertex {
        let i = self.len;
        if let Some(v) = self.slots.get_mut(i) {
            v.set_surface(point, wo, beta);
        } else {
            self.slots.push(Vertex::surface(point, wo, beta));
        }
        self.len += 1;
        &mut self.slots[i]
    }
}

impl Deref for Subpath {
    type Target = [Vertex];
    #[inline]
    fn deref(&self) -> &[Vertex] {
        &self.slots[..self.len]
    }
}

impl DerefMut for Subpath {
    #[inline]
    fn deref_mut(&mut self) -> &mut [Vertex] {
        &mut self.slots[..self.len]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::SurfacePoint;

    fn point(x: f64) -> SurfacePoint {
        SurfacePoint::flat(DVec3::new(x, 0.0, 0.0), DVec3::Z, 0)
    }

    #[test]
    fn a_cleared_subpath_reads_as_empty_and_refills_its_slots() {
        let mut s = Subpath::new();
        s.push_surface(&point(1.0), DVec3::Z, Rgb::WHITE).pdf_fwd = 3.0;
        s.push_surface(&point(2.0), DVec3::Z, Rgb::WHITE).delta = true;
        assert_eq!(s.len(), 2);
        s.clear();
        assert!(s.is_empty());
        let v = s.push_surface(&point(5.0), -DVec3::Z, Rgb::splat(0.5));
        // Every field but the BSDF is the new vertex's, none left from the slot's last occupant.
        assert_eq!(v.point.p.x, 5.0);
        assert_eq!(v.wo, -DVec3::Z);
        assert_eq!((v.pdf_fwd, v.pdf_rev, v.delta), (0.0, 0.0, false));
        assert_eq!(s.len(), 1);
        assert_eq!(s.iter().map(|v| v.point.p.x).collect::<Vec<_>>(), [5.0]);
    }
}
