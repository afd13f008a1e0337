//! The regions of the solid on a grid, for the clip plane's section: each cell holds the
//! colour slot of the coarse tet its centre lies in (plus one; 0 outside every tet). The
//! renderer uploads it as a 3D texture and colours the section's cap by it, so the cut shows
//! enamel, dentin and pulp where they lie. The cap's outline (where the solid is) comes from
//! the surface itself (a stencil parity), so a drilled cavity is exact in the section; only
//! the boundaries between regions are at the grid's resolution.

use std::sync::Arc;

use tetradrill_core::mesh::Mesh;
use tetradrill_core::{TetId, Vec3};

/// Cells along the grid's longest side.
pub const GRID_CELLS: u32 = 160;

/// The regions on a grid.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelGrid {
    /// The corner of cell (0, 0, 0).
    pub origin: Vec3,
    /// A cell's side.
    pub cell: f32,
    /// Cells along x, y, z.
    pub dims: [u32; 3],
    /// Slot + 1 of each cell (0: outside), x fastest.
    pub cells: Vec<u8>,
}

/// A grid shared with the viewer (full snapshots carry the same allocation).
pub type LabelGridRef = Arc<LabelGrid>;

impl LabelGrid {
    /// The grid of `mesh`'s tets with colour slots `slots` (one per tet), at most `cells`
    /// cells along the longest side of the mesh's bounding box. Each tet marks the cells whose
    /// centres it contains (barycentric test with a small tolerance, so a centre on a shared
    /// face is taken by one of its tets). Work: the cells of every tet's bounding box.
    pub fn of_mesh(mesh: &Mesh<'_>, slots: &[u8], cells: u32) -> Option<LabelGrid> {
        let n = mesh.tet_count();
        if n == 0 || slots.len() != n {
            return None;
        }
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for p in mesh.positions() {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let ext = hi - lo;
        let longest = ext.max_element();
        if !(longest > 0.0 && longest.is_finite()) {
            return None;
        }
        let cell = longest / cells.max(2) as f32;
        let dims = [0, 1, 2].map(|k| ((ext[k] / cell).ceil() as u32).clamp(1, cells.max(2)));
        let mut out = vec![0u8; (dims[0] * dims[1] * dims[2]) as usize];
        for (t, &slot) in slots.iter().enumerate() {
            let [a, b, c, d] = mesh.tet_positions(TetId::from_idx(t));
            let Some(weights) = Barycentric::of(a, b, c, d) else {
                continue;
            };
            let (tlo, thi) = (a.min(b).min(c.min(d)), a.max(b).max(c.max(d)));
            let range = |k: usize| {
                let i0 = ((tlo[k] - lo[k]) / cell - 0.5).ceil().max(0.0) as u32;
                let i1 = (((thi[k] - lo[k]) / cell - 0.5).floor().max(-1.0) as i64)
                    .min(dims[k] as i64 - 1);
                (i0, i1)
            };
            let ((x0, x1), (y0, y1), (z0, z1)) = (range(0), range(1), range(2));
            for z in z0 as i64..=z1 {
                for y in y0 as i64..=y1 {
                    for x in x0 as i64..=x1 {
                        let p =
                            lo + cell * Vec3::new(x as f32 + 0.5, y as f32 + 0.5, z as f32 + 0.5);
                        let w = weights.at(p);
                        let eps = -1e-5;
                        if w.x >= eps && w.y >= eps && w.z >= eps && w.x + w.y + w.z <= 1.0 - eps {
                            let i = (x as u32 + dims[0] * (y as u32 + dims[1] * z as u32)) as usize;
                            out[i] = slot.saturating_add(1);
                        }
                    }
                }
            }
        }
        Some(LabelGrid {
            origin: lo,
            cell,
            dims,
            cells: out,
        })
    }

    /// The slot + 1 at `p` (0 outside the grid or outside every tet).
    pub fn at(&self, p: Vec3) -> u8 {
        let q = (p - self.origin) / self.cell;
        if q.min_element() < 0.0 {
            return 0;
        }
        let [x, y, z] = [q.x as u32, q.y as u32, q.z as u32];
        if x >= self.dims[0] || y >= self.dims[1] || z >= self.dims[2] {
            return 0;
        }
        self.cells[(x + self.dims[0] * (y + self.dims[1] * z)) as usize]
    }
}

/// Barycentric weights of `b`, `c`, `d` in a tet `a b c d` (Cramer's rule).
struct Barycentric {
    a: Vec3,
    e: [Vec3; 3],
    inv_det: f32,
}

impl Barycentric {
    /// `None` for a flat tet.
    fn of(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> Option<Barycentric> {
        let e = [b - a, c - a, d - a];
        let det = e[0].dot(e[1].cross(e[2]));
        let scale = e[0].length() * e[1].length() * e[2].length();
        (det.abs() > 1e-9 * scale && det.is_finite()).then(|| Barycentric {
            a,
            e,
            inv_det: 1.0 / det,
        })
    }

    /// The weights of `b`, `c`, `d` at `p` (that of `a` is one minus their sum).
    fn at(&self, p: Vec3) -> Vec3 {
        let r = p - self.a;
        let [e1, e2, e3] = self.e;
        Vec3::new(
            r.dot(e2.cross(e3)),
            e1.dot(r.cross(e3)),
            e1.dot(e2.cross(r)),
        ) * self.inv_det
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_are_one_at_their_corner() {
        let (a, b, c, d) = (
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 3.0, 0.0),
            Vec3::new(0.0, 0.0, 4.0),
        );
        let w = Barycentric::of(a, b, c, d).expect("not flat");
        assert_eq!(w.at(b), Vec3::X);
        assert_eq!(w.at(c), Vec3::Y);
        assert_eq!(w.at(d), Vec3::Z);
        let m = w.at((a + b + c + d) / 4.0);
        assert!((m - Vec3::splat(0.25)).abs().max_element() < 1e-6, "{m}");
        assert!(Barycentric::of(a, b, c, b + c).is_none(), "flat");
    }
}
