//! Ray queries over the obvhs CwBvh: obvhs's own `traverse!` loop, driven with a node test that
//! checks a node's eight children in one AVX2 pass (x86-64-v3 builds; elsewhere obvhs's test).
//!
//! The AVX2 test does exactly the arithmetic of obvhs's `CwBvhNode::intersect_ray` (a multiply
//! then an add per slab, the same min/max order), so it returns the same child mask bit for bit
//! and images do not change; `tests` checks that against obvhs on random nodes and rays.

use glam::UVec2;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray;

/// obvhs's nearest box distance a CwBvh node accepts (its `EPSILON`, not exported; the tests
/// fail if obvhs's differs).
#[cfg(any(test, all(target_arch = "x86_64", target_feature = "avx2")))]
const NODE_TMIN: f32 = 1e-4;

/// The closest primitive along `ray`: `hit(ray, id)` is primitive `id`'s hit distance (or
/// infinity); each distance below the current `ray.tmax` becomes the new limit. Returns the
/// final limit (`ray.tmax` when nothing was hit).
#[inline]
pub(super) fn closest(bvh: &CwBvh, mut ray: Ray, mut hit: impl FnMut(&Ray, usize) -> f32) -> f32 {
    let mut state = bvh.new_traversal(ray.direction);
    let mut node;
    obvhs::traverse!(bvh, node, state, children_hit(node, &ray, state.oct_inv4), {
        let t = hit(&ray, state.primitive_id as usize);
        if t < ray.tmax {
            ray.tmax = t;
        }
    });
    ray.tmax
}

/// Whether `hit(ray, id)` gives a distance below `ray.tmax` for any primitive; stops at the first.
#[inline]
pub(super) fn any(bvh: &CwBvh, ray: Ray, mut hit: impl FnMut(&Ray, usize) -> f32) -> bool {
    let mut state = bvh.new_traversal(ray.direction);
    let mut node;
    let mut found = false;
    'search: {
        obvhs::traverse!(bvh, node, state, children_hit(node, &ray, state.oct_inv4), {
            if hit(&ray, state.primitive_id as usize) < ray.tmax {
                found = true;
                break 'search;
            }
        });
    }
    found
}

/// The traversal hit mask of the children of `node` that `ray` enters (obvhs's layout: inner
/// children in the top byte, leaf primitives in the low 24 bits).
#[inline(always)]
fn children_hit(node: &CwBvhNode, ray: &Ray, oct_inv4: u32) -> u32 {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    {
        // SAFETY: the build targets AVX2 (cfg above).
        unsafe { children_hit_avx2(node, ray, oct_inv4) }
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    {
        node.intersect_ray(ray, oct_inv4)
    }
}

/// [`children_hit`] with the eight slab tests in 8-wide AVX2 registers.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[inline(always)]
unsafe fn children_hit_avx2(node: &CwBvhNode, ray: &Ray, oct_inv4: u32) -> u32 {
    use glam::Vec3A;
    use std::arch::x86_64::*;
    // Entry and exit distances are linear in the quantised coordinates: t = q·scale + offset.
    let scale = node.compute_extent() * ray.inv_direction;
    let offset = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    // Eight quantised coordinates as floats.
    let load = |q: &[u8; 8]| _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(q.as_ptr().cast())));
    // Near and far planes of one axis: the low corner is near unless the ray runs backwards.
    let slab = |lo: &[u8; 8], hi: &[u8; 8], negative: bool, scale: f32, offset: f32| {
        let (near, far) = if negative { (hi, lo) } else { (lo, hi) };
        let (scale, offset) = (_mm256_set1_ps(scale), _mm256_set1_ps(offset));
        (
            _mm256_add_ps(_mm256_mul_ps(load(near), scale), offset),
            _mm256_add_ps(_mm256_mul_ps(load(far), scale), offset),
        )
    };
    let d = ray.direction;
    let (x0, x1) = slab(&node.child_min_x, &node.child_max_x, d.x < 0.0, scale.x, offset.x);
    let (y0, y1) = slab(&node.child_min_y, &node.child_max_y, d.y < 0.0, scale.y, offset.y);
    let (z0, z1) = slab(&node.child_min_z, &node.child_max_z, d.z < 0.0, scale.z, offset.z);
    let tmin = _mm256_max_ps(_mm256_max_ps(x0, _mm256_max_ps(y0, z0)), _mm256_set1_ps(NODE_TMIN));
    let tmax = _mm256_min_ps(_mm256_min_ps(x1, _mm256_min_ps(y1, z1)), _mm256_set1_ps(ray.tmax));
    let entered = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax));
    // Each entered child contributes its bits shifted to its place; OR the eight lanes.
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let widen = |eight_bytes: u64| _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(eight_bytes as i64));
    let bits = _mm256_and_si256(_mm256_sllv_epi32(widen(child_bits8), widen(bit_index8)), entered);
    let half = _mm_or_si128(_mm256_castsi256_si128(bits), _mm256_extracti128_si256::<1>(bits));
    let quarter = _mm_or_si128(half, _mm_unpackhi_epi64(half, half));
    let eighth = _mm_or_si128(quarter, _mm_srli_epi64::<32>(quarter));
    _mm_cvtsi128_si32(eighth) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;
    use obvhs::cwbvh::builder::build_cwbvh;
    use obvhs::{aabb::Aabb, BvhBuildParams};
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;
    use std::time::Duration;

    /// A uniform random point of the cube [-half, half]³.
    fn point(rng: &mut Pcg32, half: f32) -> Vec3A {
        Vec3A::from_array(std::array::from_fn(|_| rng.random_range(-half..half)))
    }

    /// A random unit direction; an eighth of its components are exactly zero (the slab order's
    /// edge case: obvhs's inverse of 0 is ±1/ε by the sign bit, which vitrum makes +0).
    fn direction(rng: &mut Pcg32) -> Vec3A {
        let mut d = point(rng, 1.0);
        for i in 0..3 {
            if rng.random_range(0..8) == 0 {
                d[i] = 0.0;
            }
        }
        d.try_normalize().unwrap_or(Vec3A::X) + Vec3A::ZERO
    }

    /// `node` with every child slot made a one-primitive leaf whose primitive is its own bit, so
    /// that the mask shows the slab test of each of the eight lanes.
    fn lane_probe(node: &CwBvhNode) -> CwBvhNode {
        let mut probe = *node;
        probe.imask = 0;
        probe.child_meta = std::array::from_fn(|k| 0b0010_0000 | k as u8);
        probe
    }

    /// A node of random bytes: any grid origin and scale, any slot layout, child boxes anywhere
    /// in the grid (an eighth of them inverted, which nothing enters).
    fn random_node(rng: &mut Pcg32) -> CwBvhNode {
        let mut node = CwBvhNode::default();
        let mut byte = || rng.random_range(0..=255u8);
        for k in 0..8 {
            node.child_meta[k] = byte();
            for (lo, hi) in [
                (&mut node.child_min_x, &mut node.child_max_x),
                (&mut node.child_min_y, &mut node.child_max_y),
                (&mut node.child_min_z, &mut node.child_max_z),
            ] {
                let (a, b) = (byte(), byte());
                let inverted = byte() < 32;
                (lo[k], hi[k]) = if inverted { (a.max(b), a.min(b)) } else { (a.min(b), a.max(b)) };
            }
        }
        node.imask = byte();
        node.e = std::array::from_fn(|_| rng.random_range(110..=130u8)); // scales 2^-17 … 2^3
        node.p = point(rng, 10.0).into();
        node
    }

    /// The ray lengths where the node test's clamps decide: around obvhs's nearest accepted box
    /// distance (1e-4), zero, infinity, or an ordinary length.
    fn ray_length(rng: &mut Pcg32) -> f32 {
        match rng.random_range(0..12) {
            0 => NODE_TMIN,
            1 => NODE_TMIN.next_up(),
            2 => NODE_TMIN.next_down(),
            3 => 0.0,
            4 => f32::INFINITY,
            _ => rng.random_range(1e-3..40.0),
        }
    }

    /// vitrum's node test against obvhs's on built and random nodes, each also as a lane probe.
    /// (A build without AVX2 uses obvhs's test itself, and this compares it with itself.)
    #[test]
    fn node_test_matches_obvhs_bit_for_bit() {
        let mut rng = Pcg32::seed_from_u64(11);
        let boxes: Vec<Aabb> = (0..3000)
            .map(|_| {
                // Some boxes flat in z, as axis-aligned quads are.
                let (c, h) = (point(&mut rng, 9.0), point(&mut rng, 1.0).abs());
                let h = if rng.random_range(0..4) == 0 { h * Vec3A::new(1.0, 1.0, 0.0) } else { h };
                Aabb::new(c - h, c + h)
            })
            .collect();
        let bvh = build_cwbvh(&boxes, BvhBuildParams::medium_build(), &mut Duration::default());
        assert!(bvh.nodes.len() > 50);
        let (mut lanes_entered, mut lanes_missed) = (0, 0);
        for _ in 0..100_000 {
            let node = if rng.random_range(0..2) == 0 {
                bvh.nodes[rng.random_range(0..bvh.nodes.len())]
            } else {
                random_node(&mut rng)
            };
            // From outside or inside the node's grid, towards the centre of a child box or
            // anywhere; some directions along the axes or with exactly zero components.
            let to_world = |q: Vec3A| Vec3A::from(node.p) + node.compute_extent() * q;
            let k = rng.random_range(0..8);
            let centre = |lo: &[u8; 8], hi: &[u8; 8]| 0.5 * (lo[k] as f32 + hi[k] as f32);
            let target = to_world(Vec3A::new(
                centre(&node.child_min_x, &node.child_max_x),
                centre(&node.child_min_y, &node.child_max_y),
                centre(&node.child_min_z, &node.child_max_z),
            ));
            let o = if rng.random_range(0..4) == 0 {
                to_world((point(&mut rng, 1.0) + 1.0) * 127.5)
            } else {
                point(&mut rng, 12.0)
            };
            let d = match rng.random_range(0..6) {
                0 => direction(&mut rng),
                1 => [Vec3A::X, Vec3A::Y, Vec3A::Z][rng.random_range(0..3)] * -1.0 + Vec3A::ZERO,
                _ => (target - o).try_normalize().unwrap_or(Vec3A::Z) + Vec3A::ZERO,
            };
            let ray = Ray::new(o, d, 0.0, ray_length(&mut rng));
            let oct = bvh.new_traversal(d).oct_inv4;
            for node in [node, lane_probe(&node)] {
                assert_eq!(
                    children_hit(&node, &ray, oct),
                    node.intersect_ray(&ray, oct),
                    "{node:?}, {ray:?}"
                );
            }
            let lanes = children_hit(&lane_probe(&node), &ray, oct).count_ones();
            lanes_entered += lanes;
            lanes_missed += 8 - lanes;
        }
        // Both outcomes are common, so each lane's comparison is tested both ways.
        assert!(lanes_entered > 50_000 && lanes_missed > 50_000, "{lanes_entered} / {lanes_missed}");
    }

    #[test]
    fn queries_match_obvhs_traversal() {
        let mut rng = Pcg32::seed_from_u64(5);
        let spheres: Vec<(Vec3A, f32)> =
            (0..500).map(|_| (point(&mut rng, 9.0), rng.random_range(0.1..0.8))).collect();
        let boxes: Vec<Aabb> = spheres.iter().map(|&(c, r)| Aabb::new(c - r, c + r)).collect();
        let bvh = build_cwbvh(&boxes, BvhBuildParams::medium_build(), &mut Duration::default());
        let sphere_t = |ray: &Ray, id: usize| {
            let (c, r) = spheres[bvh.primitive_indices[id] as usize];
            let oc = ray.origin - c;
            let b = oc.dot(ray.direction);
            let disc = b * b - (oc.length_squared() - r * r);
            let t = -b - disc.max(0.0).sqrt();
            if disc >= 0.0 && t > 0.0 && t < ray.tmax {
                t
            } else {
                f32::INFINITY
            }
        };
        let mut hits = 0;
        for _ in 0..5000 {
            let ray = Ray::new(point(&mut rng, 10.0), direction(&mut rng), 0.0, rng.random_range(1.0..30.0));
            let mut reference = obvhs::ray::RayHit::none();
            let found = bvh.ray_traverse(ray, &mut reference, sphere_t);
            let t = closest(&bvh, ray, sphere_t);
            assert_eq!(t < ray.tmax, found);
            if found {
                assert_eq!(t, reference.t);
                hits += 1;
            }
            assert_eq!(any(&bvh, ray, sphere_t), !bvh.ray_traverse_miss(ray, sphere_t));
        }
        assert!(hits > 500, "only {hits} hits");
    }
}
