//! Planar convex polygons.

use glam::{Vec2, Vec3};

use super::{
    bounds_of, planar_surface, plane_hit, plane_point, seam_slack, unit_or, Bounds, Ray, SurfaceHit,
};

/// Largest allowed distance of a vertex from the polygon's plane, relative to its diameter.
/// Generous enough for hand-typed or rounded coordinates; the polygon is then treated as its
/// projection onto the plane.
const PLANAR_TOLERANCE: f32 = 1e-4;

/// Smallest allowed `2·area / diameter²` (the polygon is otherwise a degenerate sliver or a
/// collinear chain of points); also the relative tolerance of the convexity and
/// coincident-vertex tests, so that vertices on an edge's line (180° corners) are accepted.
const DEGENERACY_TOLERANCE: f32 = 1e-6;

/// One edge of the polygon as an inward-facing in-plane line.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Edge {
    /// Unit in-plane normal pointing into the polygon.
    inward: Vec3,
    /// `inward · (vertex − reference)` for the edge's start vertex.
    offset: f32,
}

/// A planar convex polygon, counter-clockwise when seen from its normal side.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    edges: Vec<Edge>,
    /// Vertex centroid: the point the plane passes through and all offsets are taken from.
    reference: Vec3,
    normal: Vec3,
    /// In-plane texture axes, and the origin and reciprocal extent of uv in their coordinates.
    uv_axes: (Vec3, Vec3),
    uv_origin: Vec2,
    uv_scale: Vec2,
    /// Diameter bound (twice the largest vertex distance from the centroid).
    size: f32,
    area: f32,
    /// Bounds of the vertices and of their projections onto the plane (what is intersected).
    bounds: Bounds,
}

impl Polygon {
    /// Unit normal (the polygon is counter-clockwise around it).
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// The corners of the polygon that is intersected (the given vertices projected onto the
    /// plane), counter-clockwise around the normal, recovered from the edge lines; a vertex
    /// between two collinear edges (a 180° corner) is left out, which keeps the same shape.
    pub fn vertices(&self) -> Vec<Vec3> {
        let count = self.edges.len();
        (0..count)
            .filter_map(|i| {
                // Vertex i is where the line of edge i − 1 meets the line of edge i:
                // q = x·a + y·b with q·a = offset_a and q·b = offset_b.
                let (ea, eb) = (self.edges[(i + count - 1) % count], self.edges[i]);
                let c = ea.inward.dot(eb.inward);
                let det = 1.0 - c * c;
                (det > 1e-6).then(|| {
                    let x = (ea.offset - c * eb.offset) / det;
                    let y = (eb.offset - c * ea.offset) / det;
                    self.reference + x * ea.inward + y * eb.inward
                })
            })
            .collect()
    }
}

impl Polygon {
    /// Validates and builds a convex polygon; the error says which requirement failed.
    pub fn new(vertices: Vec<Vec3>) -> Result<Polygon, String> {
        let count = vertices.len();
        if count < 3 {
            return Err(format!("a polygon needs at least 3 vertices, got {count}"));
        }
        if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
            return Err(format!("polygon vertex {i} is not finite: {}", vertices[i]));
        }
        let reference = vertices.iter().sum::<Vec3>() / count as f32;
        let size = 2.0 * vertices.iter().map(|&v| (v - reference).length()).fold(0.0, f32::max);
        let next = |i: usize| (i + 1) % count;
        for i in 0..count {
            if (vertices[next(i)] - vertices[i]).length() <= DEGENERACY_TOLERANCE * size {
                return Err(format!("degenerate polygon: vertices {i} and {} coincide", next(i)));
            }
        }
        // Newell's method, relative to the centroid: twice the area vector.
        let newell: Vec3 =
            (0..count).map(|i| (vertices[i] - reference).cross(vertices[next(i)] - reference)).sum();
        let twice_area = newell.length();
        if twice_area <= DEGENERACY_TOLERANCE * size * size || twice_area.is_nan() {
            return Err("degenerate polygon: the vertices are collinear (zero area)".to_string());
        }
        let normal = unit_or(newell, Vec3::ZERO);
        for (i, &v) in vertices.iter().enumerate() {
            let off = normal.dot(v - reference).abs();
            if off > PLANAR_TOLERANCE * size {
                return Err(format!(
                    "polygon is not planar: vertex {i} lies {off} from the plane \
                     (tolerance {})",
                    PLANAR_TOLERANCE * size
                ));
            }
        }
        let mut edges = Vec::with_capacity(count);
        for i in 0..count {
            let inward = unit_or(normal.cross(vertices[next(i)] - vertices[i]), Vec3::ZERO);
            // Every vertex must lie on the inner side of every edge's line; this also rejects
            // self-intersecting stars, whose turns all have the same sign.
            for (k, &v) in vertices.iter().enumerate() {
                if inward.dot(v - vertices[i]) < -DEGENERACY_TOLERANCE * size {
                    return Err(format!(
                        "polygon is not convex: vertex {k} lies outside the edge from vertex {i} \
                         to vertex {}",
                        next(i)
                    ));
                }
            }
            edges.push(Edge { inward, offset: inward.dot(vertices[i] - reference) });
        }
        let tu = unit_or(vertices[1] - vertices[0], Vec3::ZERO);
        let uv_axes = (tu, normal.cross(tu));
        let planar = |v: Vec3| Vec2::new((v - reference).dot(uv_axes.0), (v - reference).dot(uv_axes.1));
        let lo = vertices.iter().map(|&v| planar(v)).fold(Vec2::INFINITY, Vec2::min);
        let hi = vertices.iter().map(|&v| planar(v)).fold(Vec2::NEG_INFINITY, Vec2::max);
        let projected = vertices.iter().map(|&v| v - normal.dot(v - reference) * normal);
        let bounds = bounds_of(&vertices.iter().copied().chain(projected).collect::<Vec<_>>());
        Ok(Polygon {
            edges,
            reference,
            normal,
            uv_axes,
            uv_origin: lo,
            uv_scale: (hi - lo).recip(),
            size,
            area: 0.5 * twice_area,
            bounds,
        })
    }

    /// Nearest hit distance in the open interval (`tmin`, `tmax`).
    #[inline]
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<f32> {
        let (t, f, q) = plane_hit(self.normal, self.reference, ray, tmin, tmax)?;
        let slack = seam_slack(self.size, self.reference, f);
        self.edges.iter().all(|e| e.inward.dot(q) - e.offset >= -slack).then_some(t)
    }

    /// Full hit record for a hit at `t`; uv is the position within the polygon's planar bounding
    /// rectangle (first edge along u).
    pub fn surface(&self, ray: &Ray, t: f32) -> SurfaceHit {
        let q = plane_point(self.normal, self.reference, ray, t);
        let planar = Vec2::new(q.dot(self.uv_axes.0), q.dot(self.uv_axes.1));
        let uv = ((planar - self.uv_origin) * self.uv_scale).clamp(Vec2::ZERO, Vec2::ONE);
        planar_surface(self.normal, self.reference, q, t, uv)
    }

    /// Bounds of the vertices and of their projections onto the plane (what is intersected).
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }

    /// Area (half the Newell vector's length).
    pub fn area(&self) -> f32 {
        self.area
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::test_support::{random_point, random_unit, ray, spawned_rays};
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;
    use std::f32::consts::TAU;

    /// Convex pentagon in the plane y = 2, counter-clockwise seen from +y.
    fn pentagon() -> Polygon {
        // (x, z): (0,0) (0,2) (2,3) (4,2) (4,0); (0,0,2) × (2,0,1) = (0,4,0), so n = +y.
        Polygon::new(vec![
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.0, 2.0, 2.0),
            Vec3::new(2.0, 2.0, 3.0),
            Vec3::new(4.0, 2.0, 2.0),
            Vec3::new(4.0, 2.0, 0.0),
        ])
        .unwrap()
    }

    #[test]
    fn pentagon_hit_and_normal() {
        let p = pentagon();
        assert_eq!(p.normal, Vec3::Y);
        assert!((p.area() - 10.0).abs() < 1e-5);
        let r = ray([1.0, 5.0, 1.0], [0.0, -1.0, 0.0]);
        let t = p.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert_eq!(t, 3.0);
        let h = p.surface(&r, t);
        assert_eq!(h.n, Vec3::Y);
        assert!((h.p - Vec3::new(1.0, 2.0, 1.0)).length() < 1e-6);
        assert!(h.uv.cmpge(Vec2::ZERO).all() && h.uv.cmple(Vec2::ONE).all());
        // The apex (2, 2, 3) and a point on the slanted edge.
        let r = ray([2.0, 3.0, 3.0], [0.0, -1.0, 0.0]);
        assert_eq!(p.intersect(&r, 0.0, f32::INFINITY), Some(1.0));
        let r = ray([1.0, 3.0, 2.5], [0.0, -1.0, 0.0]);
        assert_eq!(p.intersect(&r, 0.0, f32::INFINITY), Some(1.0));
        let b = p.bounds();
        assert_eq!((b.min, b.max), (Vec3::new(0.0, 2.0, 0.0), Vec3::new(4.0, 2.0, 3.0)));
    }

    #[test]
    fn pentagon_miss_and_open_interval() {
        let p = pentagon();
        // Beyond the apex corner, outside the slanted edge.
        assert_eq!(p.intersect(&ray([0.5, 3.0, 2.75], [0.0, -1.0, 0.0]), 0.0, 10.0), None);
        assert_eq!(p.intersect(&ray([5.0, 3.0, 1.0], [0.0, -1.0, 0.0]), 0.0, 10.0), None);
        assert_eq!(p.intersect(&ray([1.0, 3.0, 1.0], [1.0, 0.0, 0.0]), 0.0, 10.0), None);
        let r = ray([1.0, 3.0, 1.0], [0.0, -1.0, 0.0]);
        assert_eq!(p.intersect(&r, 0.0, 1.0), None);
        assert_eq!(p.intersect(&r, 1.0, 5.0), None);
        assert_eq!(p.intersect(&r, 0.5, 5.0), Some(1.0));
    }

    #[test]
    fn constructor_errors() {
        let err = |v: Vec<Vec3>| Polygon::new(v).unwrap_err();
        assert!(err(vec![Vec3::ZERO, Vec3::X]).contains("at least 3"));
        let e = err(vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::X * 3.0]);
        assert!(e.contains("collinear"), "{e}");
        let e = err(vec![Vec3::ZERO, Vec3::X, Vec3::X, Vec3::Y]);
        assert!(e.contains("coincide"), "{e}");
        let e = err(vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.1), Vec3::Y]);
        assert!(e.contains("not planar"), "{e}");
        // An arrowhead (reflex vertex at (0.5, 0.3)).
        let e = err(vec![Vec3::ZERO, Vec3::X, Vec3::new(0.5, 1.0, 0.0), Vec3::new(0.5, 0.3, 0.0)]);
        assert!(e.contains("not convex"), "{e}");
        // A pentagram: every turn has the same sign, yet it is not convex.
        let star: Vec<Vec3> = (0..5)
            .map(|k| {
                let a = TAU * (2 * k) as f32 / 5.0;
                Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        assert!(err(star).contains("not convex"));
        assert!(err(vec![Vec3::ZERO, Vec3::X, Vec3::new(f32::NAN, 0.0, 0.0)]).contains("finite"));
        // Tiny non-planarity within tolerance and a vertex on an edge are fine.
        assert!(Polygon::new(vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 1e-6), Vec3::Y]).is_ok());
        assert!(Polygon::new(vec![Vec3::ZERO, Vec3::X * 0.5, Vec3::X, Vec3::Y]).is_ok());
    }

    #[test]
    fn clockwise_order_flips_the_normal() {
        let p = Polygon::new(vec![Vec3::ZERO, Vec3::Y, Vec3::X]).unwrap();
        assert_eq!(p.normal, -Vec3::Z);
        let r = ray([0.25, 0.25, 1.0], [0.0, 0.0, -1.0]);
        assert_eq!(p.intersect(&r, 0.0, 10.0), Some(1.0));
        assert!((p.area() - 0.5).abs() < 1e-6);
    }

    #[test]
    fn spawned_rays_do_not_self_intersect() {
        let mut rng = Pcg32::seed_from_u64(31);
        let mut checked = 0;
        while checked < 2_000 {
            let center = random_point(&mut rng, 100.0);
            let normal = random_unit(&mut rng);
            let (e0, e1) = normal.any_orthonormal_pair();
            let radius = 0.01 + rng.random::<f32>() * 10.0;
            let sides = 3 + checked % 6;
            let ring: Vec<Vec3> = (0..sides)
                .map(|k| {
                    let a = TAU * k as f32 / sides as f32;
                    center + radius * (a.cos() * e0 + a.sin() * e1)
                })
                .collect();
            let Ok(p) = Polygon::new(ring) else { continue };
            let target = center + 0.5 * radius * (rng.random::<f32>() * e0 + rng.random::<f32>() * e1);
            let o = target + random_unit(&mut rng) * radius * (0.1 + 20.0 * rng.random::<f32>());
            let r = Ray::new(o, (target - o).normalize());
            let Some(t) = p.intersect(&r, 0.0, f32::INFINITY) else { continue };
            let hit = p.surface(&r, t);
            for spawned in spawned_rays(&hit, r.dir, &mut rng) {
                assert_eq!(p.intersect(&spawned, 0.0, f32::INFINITY), None, "self-hit {hit:?}");
            }
            checked += 1;
        }
    }
}
