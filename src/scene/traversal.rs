//! Ray queries over the obvhs CwBvh: obvhs's own `traverse!` loop, driven with a node test that
//! checks a node's eight children in one AVX2 pass (x86-64-v3 builds; elsewhere obvhs's test).
//!
//! The AVX2 test does exactly the arithmetic of obvhs's `CwBvhNode::intersect_ray` (a multiply
//! then an add per slab, the same min/max order), so it returns the same child mask bit for bit
//! and images do not change; `tests` checks that against obvhs on random nodes and rays.

use glam::{UVec2, Vec3A};
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray;

/// obvhs's nearest box distance a CwBvh node accepts (its `EPSILON`, not exported).
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
    use std::arch::x86_64::*;
    let extent = node.compute_extent();
    let dir_inv = extent * ray.inv_direction;
    let origin = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
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
    let (x0, x1) = slab(&node.child_min_x, &node.child_max_x, d.x < 0.0, dir_inv.x, origin.x);
    let (y0, y1) = slab(&node.child_min_y, &node.child_max_y, d.y < 0.0, dir_inv.y, origin.y);
    let (z0, z1) = slab(&node.child_min_z, &node.child_max_z, d.z < 0.0, dir_inv.z, origin.z);
    let tmin = _mm256_max_ps(_mm256_max_ps(x0, _mm256_max_ps(y0, z0)), _mm256_set1_ps(NODE_TMIN));
    let tmax = _mm256_min_ps(_mm256_min_ps(x1, _mm256_min_ps(y1, z1)), _mm256_set1_ps(ray.tmax));
    let entered = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax));
    // Each entered child contributes its bits shifted to its place; OR the eight lanes.
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let bytes = |x: u64| _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(x as i64));
    let bits = _mm256_and_si256(_mm256_sllv_epi32(bytes(child_bits8), bytes(bit_index8)), entered);
    let half = _mm_or_si128(_mm256_castsi256_si128(bits), _mm256_extracti128_si256::<1>(bits));
    let quarter = _mm_or_si128(half, _mm_unpackhi_epi64(half, half));
    let eighth = _mm_or_si128(quarter, _mm_srli_epi64::<32>(quarter));
    _mm_cvtsi128_si32(eighth) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use obvhs::cwbvh::builder::build_cwbvh;
    use obvhs::{aabb::Aabb, BvhBuildParams};
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;
    use std::time::Duration;

    /// A random unit direction, some with exactly zero components (the slab order's edge case).
    fn direction(rng: &mut Pcg32) -> Vec3A {
        let mut d =
            Vec3A::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        for i in 0..3 {
            if rng.random_range(0..8) == 0 {
                d[i] = 0.0;
            }
        }
        (d + Vec3A::splat(1e-7)).normalize() + Vec3A::ZERO
    }

    #[test]
    fn node_test_matches_obvhs_bit_for_bit() {
        let mut rng = Pcg32::seed_from_u64(11);
        let boxes: Vec<Aabb> = (0..3000)
            .map(|_| {
                let c = Vec3A::new(
                    rng.random_range(-9.0..9.0),
                    rng.random_range(-9.0..9.0),
                    rng.random_range(-9.0..9.0),
                );
                let h = Vec3A::new(
                    rng.random_range(0.0..1.0),
                    rng.random_range(0.0..1.0),
                    rng.random_range(0.0..0.5),
                );
                Aabb::new(c - h, c + h)
            })
            .collect();
        let bvh = build_cwbvh(&boxes, BvhBuildParams::medium_build(), &mut Duration::default());
        assert!(bvh.nodes.len() > 50);
        let mut entered = 0;
        for _ in 0..20_000 {
            // Rays towards a random point of a random node's grid, or in a random direction.
            let node = &bvh.nodes[rng.random_range(0..bvh.nodes.len())];
            let o = Vec3A::new(
                rng.random_range(-12.0..12.0),
                rng.random_range(-12.0..12.0),
                rng.random_range(-12.0..12.0),
            );
            let grid = Vec3A::new(
                rng.random_range(0.0..255.0),
                rng.random_range(0.0..255.0),
                rng.random_range(0.0..255.0),
            );
            let target = Vec3A::from(node.p) + node.compute_extent() * grid;
            let d = if rng.random_range(0..4) == 0 {
                direction(&mut rng)
            } else {
                (target - o).normalize() + Vec3A::ZERO
            };
            let ray = Ray::new(o, d, 0.0, rng.random_range(0.5..40.0));
            let oct = bvh.new_traversal(d).oct_inv4;
            let ours = children_hit(node, &ray, oct);
            assert_eq!(ours, node.intersect_ray(&ray, oct), "node {node:?}, ray {ray:?}");
            entered += (ours != 0) as u32;
        }
        assert!(entered > 3000, "only {entered} rays entered a child");
    }

    #[test]
    fn queries_match_obvhs_traversal() {
        let mut rng = Pcg32::seed_from_u64(5);
        let spheres: Vec<(Vec3A, f32)> = (0..500)
            .map(|_| {
                let c = Vec3A::new(
                    rng.random_range(-9.0..9.0),
                    rng.random_range(-9.0..9.0),
                    rng.random_range(-9.0..9.0),
                );
                (c, rng.random_range(0.1..0.8))
            })
            .collect();
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
            let o = Vec3A::new(
                rng.random_range(-10.0..10.0),
                rng.random_range(-10.0..10.0),
                rng.random_range(-10.0..10.0),
            );
            let ray = Ray::new(o, direction(&mut rng), 0.0, rng.random_range(1.0..30.0));
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
