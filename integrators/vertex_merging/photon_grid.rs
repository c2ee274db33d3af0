//! The photons of an iteration in a hashed uniform grid: the merge queries' index. The photons
//! themselves are sorted into the grid's bucket order (a stable counting sort, then a
//! permutation in place), so a query reads each bucket's photons as one contiguous run instead
//! of through an index into the whole store: at large photon counts that spares a cache miss per
//! photon, which kept the time per pixel from staying flat in resolution. Nothing here depends on
//! the thread count.

use super::light_paths::LightVertex;
use glam::Vec3;

/// The photons of one iteration in a hashed uniform grid of cells twice the radius wide, over
/// photons stored in bucket order.
pub(super) struct PhotonGrid {
    origin: Vec3,
    inv_cell: f32,
    mask: u64,
    /// Per bucket, the start of its photons in the sorted store (one more entry at the end).
    starts: Vec<u32>,
}

impl PhotonGrid {
    fn cell_of(&self, p: Vec3) -> [i64; 3] {
        let c = ((p - self.origin) * self.inv_cell).floor();
        [c.x as i64, c.y as i64, c.z as i64]
    }

    /// The bucket of cell `c`: the hash of its block of 2×2×2 cells, then its place in the
    /// block, so that the cells of a block have consecutive buckets and their photons lie side
    /// by side in the sorted store (a query's 2×2×2 cells span few blocks).
    fn bucket(&self, c: [i64; 3]) -> usize {
        let h = ((c[0] >> 1) as u64).wrapping_mul(73_856_093)
            ^ ((c[1] >> 1) as u64).wrapping_mul(19_349_663)
            ^ ((c[2] >> 1) as u64).wrapping_mul(83_492_791);
        let within = (c[0] & 1) | (c[1] & 1) << 1 | (c[2] & 1) << 2;
        ((h << 3 | within as u64) & self.mask) as usize
    }

    /// A grid for merges of radius `radius` over `vertices`, which it sorts into bucket order
    /// (stable: within a bucket, in their order before); returns the grid and, per vertex in its
    /// order before, its position after.
    pub fn build(vertices: &mut [LightVertex], radius: f32, origin: Vec3) -> (PhotonGrid, Vec<u32>) {
        let buckets = vertices.len().max(1).next_power_of_two();
        let mut grid = PhotonGrid {
            origin,
            inv_cell: 1.0 / (2.0 * radius),
            mask: buckets as u64 - 1,
            starts: vec![0; buckets + 1],
        };
        let keys: Vec<u32> = vertices.iter().map(|v| grid.bucket(grid.cell_of(v.p)) as u32).collect();
        for &k in &keys {
            grid.starts[k as usize + 1] += 1;
        }
        for b in 0..buckets {
            grid.starts[b + 1] += grid.starts[b];
        }
        let mut fill = grid.starts.clone();
        let position: Vec<u32> = keys
            .iter()
            .map(|&k| {
                fill[k as usize] += 1;
                fill[k as usize] - 1
            })
            .collect();
        drop((keys, fill));
        // Move every vertex to its position, one cycle of the permutation at a time.
        let mut target = position.clone();
        for i in 0..vertices.len() {
            while target[i] as usize != i {
                let t = target[i] as usize;
                vertices.swap(i, t);
                target.swap(i, t);
            }
        }
        (grid, position)
    }

    /// Call `visit` with the index of every photon within `radius` of `p`, each once.
    pub fn query(&self, vertices: &[LightVertex], p: Vec3, radius: f32, mut visit: impl FnMut(usize)) {
        let lo = self.cell_of(p - Vec3::splat(radius));
        let hi = self.cell_of(p + Vec3::splat(radius));
        let mut seen = [usize::MAX; 8];
        let mut count = 0;
        let r2 = radius * radius;
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let b = self.bucket([x, y, z]);
                    if seen[..count].contains(&b) {
                        continue;
                    }
                    if count < seen.len() {
                        seen[count] = b;
                        count += 1;
                    }
                    let start = self.starts[b] as usize;
                    for (i, v) in vertices[start..self.starts[b + 1] as usize].iter().enumerate() {
                        if (v.p - p).length_squared() <= r2 {
                            visit(start + i);
                        }
                    }
                }
            }
        }
    }
}
