//! The photons of an iteration in a hashed uniform grid: the merge queries' index. The grid keeps
//! its own compact copy of the photons, a position and the photon's index in the store
//! (`GridPhoton`, 16 bytes), in bucket order (a stable counting sort), so that a query reads
//! each bucket's candidates as one contiguous run of small records and touches the store (96
//! bytes a vertex) only for the photons within the radius, about one in twelve of the candidates
//! on `scenes/cornell-glass.toml`. The store itself stays path after path, the order the camera
//! paths' connections read it in. At the default cap the photons fill far more than the cache,
//! so a query's cost is its cache misses: this layout keeps them few (the candidates' runs, the
//! found photons), which keeps the time per pixel from growing much with the resolution. The
//! sort is stable and the buckets are visited in a fixed order, so a merge visits its photons in
//! the same order whatever the thread count (the order of the earlier layout, which sorted the
//! store itself).

use super::light_paths::LightVertex;
use glam::Vec3;

/// A photon as the grid holds it: where it is and its index in the store.
#[derive(Clone, Copy, Debug)]
struct GridPhoton {
    p: Vec3,
    index: u32,
}

/// The photons of one iteration in a hashed uniform grid of cells twice the radius wide.
pub(super) struct PhotonGrid {
    origin: Vec3,
    inv_cell: f32,
    mask: u64,
    /// Bucket `b`'s photons are `photons[starts[b]..starts[b + 1]]` (one more entry at the end,
    /// and one unused).
    starts: Vec<u32>,
    /// Per photon of the store, its bucket (kept between builds for its room).
    keys: Vec<u32>,
    /// The photons in bucket order.
    photons: Vec<GridPhoton>,
}

impl PhotonGrid {
    fn cell_of(&self, p: Vec3) -> [i64; 3] {
        let c = ((p - self.origin) * self.inv_cell).floor();
        [c.x as i64, c.y as i64, c.z as i64]
    }

    /// The bucket of cell `c`: the hash of its block of 2×2×2 cells, then its place in the
    /// block, so that the cells of a block have consecutive buckets and their photons lie side
    /// by side (a query's 2×2×2 cells span few blocks).
    fn bucket(&self, c: [i64; 3]) -> usize {
        let h = ((c[0] >> 1) as u64).wrapping_mul(73_856_093)
            ^ ((c[1] >> 1) as u64).wrapping_mul(19_349_663)
            ^ ((c[2] >> 1) as u64).wrapping_mul(83_492_791);
        let within = (c[0] & 1) | (c[1] & 1) << 1 | (c[2] & 1) << 2;
        ((h << 3 | within as u64) & self.mask) as usize
    }

    /// An empty grid, to be [built](PhotonGrid::build) for each batch of photons: its arrays
    /// keep their room from one build to the next, so that an iteration does not allocate (and
    /// fault in) them again.
    pub fn new() -> PhotonGrid {
        PhotonGrid {
            origin: Vec3::ZERO,
            inv_cell: 1.0,
            mask: 0,
            starts: vec![0, 0],
            keys: Vec::new(),
            photons: Vec::new(),
        }
    }

    /// Index the photons `vertices` for merges of radius `radius` (stable: within a bucket,
    /// photons keep their order in `vertices`), replacing what the grid held.
    pub fn build(&mut self, vertices: &[LightVertex], radius: f32, origin: Vec3) {
        let buckets = vertices.len().max(1).next_power_of_two();
        self.origin = origin;
        self.inv_cell = 1.0 / (2.0 * radius);
        self.mask = buckets as u64 - 1;
        let mut keys = std::mem::take(&mut self.keys);
        keys.clear();
        keys.reserve_exact(vertices.len());
        keys.extend(vertices.iter().map(|v| self.bucket(self.cell_of(v.p)) as u32));
        // Bucket b's count in starts[b + 2], then the running sums: starts[b + 1] is the bucket's
        // start, the cursor of its fill, which leaves it at the bucket's end; so afterwards
        // starts[b]..starts[b + 1] are bucket b's photons.
        let starts = &mut self.starts;
        starts.clear();
        starts.reserve_exact(buckets + 2);
        starts.resize(buckets + 2, 0);
        for &k in &keys {
            starts[k as usize + 2] += 1;
        }
        for b in 2..starts.len() {
            starts[b] += starts[b - 1];
        }
        // Each photon to the next free place of its bucket: the reads in order, the writes
        // independent of one another (no chain of dependent cache misses).
        self.photons.clear();
        self.photons.reserve_exact(vertices.len());
        self.photons.resize(vertices.len(), GridPhoton { p: Vec3::ZERO, index: 0 });
        for (i, (v, &k)) in vertices.iter().zip(&keys).enumerate() {
            let slot = &mut starts[k as usize + 1];
            self.photons[*slot as usize] = GridPhoton { p: v.p, index: i as u32 };
            *slot += 1;
        }
        self.keys = keys;
    }

    /// The bytes the grid holds per photon (at most): its record, its key and its share of the
    /// buckets' starts (up to two buckets per photon).
    pub const BYTES_PER_PHOTON: u64 = std::mem::size_of::<GridPhoton>() as u64 + 4 + 2 * 4;

    /// The bytes its arrays hold (their room, not only what they use).
    #[cfg(test)]
    pub fn bytes_held(&self) -> u64 {
        let photon = std::mem::size_of::<GridPhoton>();
        (self.photons.capacity() * photon + (self.keys.capacity() + self.starts.capacity()) * 4) as u64
    }

    /// The buckets a merge at `p` within `radius` reads, each once, in the order it reads them.
    pub fn buckets(&self, p: Vec3, radius: f32) -> Buckets {
        let lo = self.cell_of(p - Vec3::splat(radius));
        let hi = self.cell_of(p + Vec3::splat(radius));
        let mut out = Buckets { p, radius, list: [0; 8], count: 0 };
        // Cells are twice the radius wide: at most 2 per axis, 8 in all.
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let b = self.bucket([x, y, z]);
                    if !out.list[..out.count].contains(&b) && out.count < out.list.len() {
                        out.list[out.count] = b;
                        out.count += 1;
                    }
                }
            }
        }
        out
    }

    /// Ask for the buckets' starts in the cache ahead of the merge (a hint: results unchanged).
    pub fn prefetch_starts(&self, buckets: &Buckets) {
        for &b in buckets.list() {
            prefetch(&self.starts[b]);
        }
    }

    /// Ask for the buckets' first photons in the cache ahead of the merge (best after
    /// [`PhotonGrid::prefetch_starts`] has had time to bring the starts).
    pub fn prefetch_photons(&self, buckets: &Buckets) {
        for &b in buckets.list() {
            if let Some(photon) = self.photons.get(self.starts[b] as usize) {
                prefetch(photon);
            }
        }
    }

    /// The photons within the radius of the merge of `buckets`, found ahead of the merge's
    /// evaluation ([`Found`]), their stored vertices in `vertices` asked for in the cache (a
    /// hint), so that those cache misses overlap the work done before the merge.
    pub fn find(&self, buckets: &Buckets, vertices: &[LightVertex]) -> Found {
        let mut found = Found { list: [0; FOUND], count: 0, complete: true };
        self.query(buckets, |i| {
            if found.count == FOUND {
                found.complete = false;
                return;
            }
            found.list[found.count] = i as u32;
            found.count += 1;
            let v = &vertices[i];
            prefetch(v);
            // A vertex spans two cache lines.
            prefetch(&v.beta);
        });
        found
    }

    /// Call `visit` with the store index of every photon within the radius of the merge of
    /// `buckets`, each once.
    pub fn query(&self, buckets: &Buckets, mut visit: impl FnMut(usize)) {
        let r2 = buckets.radius * buckets.radius;
        for &b in buckets.list() {
            for photon in &self.photons[self.starts[b] as usize..self.starts[b + 1] as usize] {
                if (photon.p - buckets.p).length_squared() <= r2 {
                    visit(photon.index as usize);
                }
            }
        }
    }
}

/// The buckets of one merge ([`PhotonGrid::buckets`]): found once, read two or three times (the
/// prefetches, the query).
pub(super) struct Buckets {
    p: Vec3,
    radius: f32,
    list: [usize; 8],
    count: usize,
}

impl Buckets {
    fn list(&self) -> &[usize] {
        &self.list[..self.count]
    }
}

/// The most photons [`Found`] lists (a merge finds 0.67 on average on `scenes/cornell-glass.toml`).
const FOUND: usize = 16;

/// The photons within the radius of a merge ([`PhotonGrid::find`]): their store indices in the
/// order [`PhotonGrid::query`] visits them, if there are at most [`FOUND`].
pub(super) struct Found {
    list: [u32; FOUND],
    count: usize,
    complete: bool,
}

impl Found {
    /// Call `visit` with the store index of every photon of the merge, in the order of
    /// [`PhotonGrid::query`] (which it runs again when there were too many to list).
    pub fn visit(&self, grid: &PhotonGrid, buckets: &Buckets, mut visit: impl FnMut(usize)) {
        if self.complete {
            for &i in &self.list[..self.count] {
                visit(i as usize);
            }
        } else {
            grid.query(buckets, visit);
        }
    }
}

/// Ask the processor to bring the cache line of `x` into its caches: a hint that changes no
/// result, which lets the line's cache miss overlap other work (the merge's photons fill far
/// more than the cache at the default cap).
#[inline(always)]
fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing the program sees and never faults, and SSE (which
    // provides it) is part of every x86-64 processor.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>((x as *const T).cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}
