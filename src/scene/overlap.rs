//! Coincident surfaces of different objects: the same plane over an area, the same sphere, the
//! same cylinder over a stretch of its height. Which of two coincident surfaces a ray hits is
//! decided by roundoff, so the compiler warns about them (`vitrum info`, `vitrum render`).
//!
//! The test is cheap and approximate: every pair of analytic primitives of different objects
//! (O(n²), at most [`MAX_CHECKED`] primitives; mesh triangles are never checked) is compared
//! within a relative tolerance [`TOLERANCE`] of the shapes' size and position. Planar regions
//! (quads, disks, polygons) count as overlapping when their bounding rectangles in the common
//! plane overlap with a positive area: a disk next to the corner of a quad can be reported
//! although the two do not touch. Surfaces that only meet along an edge (a wall split at a
//! liquid level, a quad meeting a quad) are not reported.

use super::{ObjectSummary, Primitive};
use crate::geometry::Shape;
use glam::{Vec2, Vec3};

/// Relative tolerance of "the same" plane, centre, radius or axis, in units of the shapes' size
/// plus the magnitude of their coordinates.
pub const TOLERANCE: f32 = 1e-5;

/// Most analytic primitives compared pairwise; a scene with more is not checked.
pub const MAX_CHECKED: usize = 4096;

/// A planar region: its plane (unit normal, a point) and its outline points in the plane.
struct Planar {
    normal: Vec3,
    point: Vec3,
    outline: Vec<Vec3>,
    size: f32,
}

fn planar(shape: &Shape) -> Option<Planar> {
    match shape {
        Shape::Quad(q) => {
            let c = q.corner();
            let outline = vec![c, c + q.u(), c + q.u() + q.v(), c + q.v()];
            Some(Planar { normal: q.normal(), point: c, outline, size: q.u().length() + q.v().length() })
        }
        Shape::Disk(d) => {
            let (t1, t2) = d.normal().any_orthonormal_pair();
            let r = d.radius();
            let c = d.center();
            // The circle's bounding square in any frame of the plane holds the circle.
            let outline = vec![c + r * (t1 + t2), c + r * (t1 - t2), c - r * (t1 + t2), c - r * (t1 - t2)];
            Some(Planar { normal: d.normal(), point: c, outline, size: 2.0 * r })
        }
        Shape::Polygon(p) => {
            let outline = p.vertices();
            let size = p.bounds().max.distance(p.bounds().min);
            Some(Planar { normal: p.normal(), point: outline[0], outline, size })
        }
        _ => None,
    }
}

/// The tolerance for two shapes of sizes `a`, `b` at points `p`, `q`.
fn tolerance(a: f32, b: f32, p: Vec3, q: Vec3) -> f32 {
    TOLERANCE * (a.max(b) + p.abs().max_element().max(q.abs().max_element()))
}

/// Whether two intervals overlap over more than `eps`.
fn overlap_1d((a0, a1): (f32, f32), (b0, b1): (f32, f32), eps: f32) -> bool {
    a1.min(b1) - a0.max(b0) > eps
}

/// What two surfaces share, if they coincide over an area: "the same plane", "the same
/// sphere", "the same cylinder".
pub fn coincide(a: &Shape, b: &Shape) -> Option<&'static str> {
    match (a, b) {
        (Shape::Sphere(s), Shape::Sphere(t)) => {
            let eps = tolerance(s.radius(), t.radius(), s.center(), t.center());
            if s.center().distance(t.center()) > eps || (s.radius() - t.radius()).abs() > eps {
                return None;
            }
            // The kept zones, as height intervals along the first sphere's axis.
            let r = s.radius();
            let zone = |lo: f32, hi: f32| (lo.clamp(-r, r), hi.clamp(-r, r));
            let first = zone(s.min_height(), s.max_height());
            let cos = s.axis().dot(t.axis());
            let second = if !t.is_clipped() {
                (-r, r)
            } else if cos > 1.0 - TOLERANCE {
                zone(t.min_height(), t.max_height())
            } else if cos < -1.0 + TOLERANCE {
                zone(-t.max_height(), -t.min_height())
            } else {
                // Zones about different axes: assume they overlap (spheres are rarely cut so).
                (-r, r)
            };
            overlap_1d(first, second, eps).then_some("the same sphere")
        }
        (Shape::Cylinder(c), Shape::Cylinder(d)) => {
            let eps = tolerance(c.radius() + c.height(), d.radius() + d.height(), c.base(), d.base());
            let axis = c.axis();
            if axis.dot(d.axis()).abs() < 1.0 - TOLERANCE || (c.radius() - d.radius()).abs() > eps {
                return None;
            }
            let offset = d.base() - c.base();
            if (offset - axis * offset.dot(axis)).length() > eps {
                return None;
            }
            let along = offset.dot(axis);
            let span = along + d.height() * d.axis().dot(axis);
            overlap_1d((0.0, c.height()), (along.min(span), along.max(span)), eps)
                .then_some("the same cylinder")
        }
        _ => {
            let (p, q) = (planar(a)?, planar(b)?);
            let eps = tolerance(p.size, q.size, p.point, q.point);
            if p.normal.dot(q.normal).abs() < 1.0 - TOLERANCE || (q.point - p.point).dot(p.normal).abs() > eps
            {
                return None;
            }
            let (t1, t2) = p.normal.any_orthonormal_pair();
            let rect = |outline: &[Vec3]| {
                let flat = outline.iter().map(|&x| Vec2::new((x - p.point).dot(t1), (x - p.point).dot(t2)));
                flat.fold((Vec2::INFINITY, Vec2::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)))
            };
            let ((alo, ahi), (blo, bhi)) = (rect(&p.outline), rect(&q.outline));
            let both = overlap_1d((alo.x, ahi.x), (blo.x, bhi.x), eps)
                && overlap_1d((alo.y, ahi.y), (blo.y, bhi.y), eps);
            both.then_some("the same plane")
        }
    }
}

/// One warning per pair of objects with coincident surfaces, naming both objects (in the order
/// of the scene file) and what they share.
pub fn coincident_surfaces(primitives: &[Primitive], objects: &[ObjectSummary]) -> Vec<String> {
    let checked: Vec<&Primitive> =
        primitives.iter().filter(|p| !matches!(p.shape, Shape::Triangle(_))).collect();
    if checked.len() > MAX_CHECKED {
        return vec![format!(
            "{} analytic surfaces: more than {MAX_CHECKED}, so coincident surfaces were not looked for",
            checked.len()
        )];
    }
    let bounds: Vec<_> = checked.iter().map(|p| p.shape.bounds()).collect();
    let mut pairs: Vec<(u32, u32, &'static str)> = Vec::new();
    for i in 0..checked.len() {
        for j in i + 1..checked.len() {
            let (a, b) = (checked[i], checked[j]);
            let (lo, hi) = (a.object.min(b.object), a.object.max(b.object));
            if lo == hi || a.velocity != b.velocity || pairs.iter().any(|&(x, y, _)| (x, y) == (lo, hi)) {
                continue;
            }
            let (ba, bb) = (bounds[i], bounds[j]);
            let slack = TOLERANCE * (ba.max - ba.min).max(bb.max - bb.min).max_element();
            if (ba.min - bb.max).max_element() > slack || (bb.min - ba.max).max_element() > slack {
                continue;
            }
            if let Some(what) = coincide(&a.shape, &b.shape) {
                pairs.push((lo, hi, what));
            }
        }
    }
    pairs.sort();
    pairs
        .into_iter()
        .map(|(a, b, what)| {
            format!(
                "objects `{}` and `{}` have coincident surfaces ({what}): which one a ray hits is decided by \
                 roundoff; make them one interface or move one apart",
                objects[a as usize].name, objects[b as usize].name
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Cylinder, Disk, Polygon, Quad, Sphere};

    fn quad(corner: [f32; 3], u: [f32; 3], v: [f32; 3]) -> Shape {
        Shape::Quad(Box::new(Quad::new(Vec3::from(corner), Vec3::from(u), Vec3::from(v))))
    }

    fn disk(center: [f32; 3], normal: Vec3, r: f32) -> Shape {
        Shape::Disk(Box::new(Disk::new(Vec3::from(center), normal, r, 0.0)))
    }

    fn cylinder(base: [f32; 3], r: f32, h: f32) -> Shape {
        Shape::Cylinder(Box::new(Cylinder::new(Vec3::from(base), Vec3::Y, r, h)))
    }

    #[test]
    fn coplanar_regions_that_overlap_coincide_and_neighbours_do_not() {
        let floor = quad([-1.0, 0.0, -1.0], [0.0, 0.0, 2.0], [2.0, 0.0, 0.0]);
        // A glass bottom exactly on the floor (the normals opposite) coincides with it ...
        assert_eq!(coincide(&floor, &disk([0.2, 0.0, 0.1], -Vec3::Y, 0.3)), Some("the same plane"));
        // ... one lifted by 1 mm does not, nor does one beside the floor or a wall meeting it.
        assert_eq!(coincide(&floor, &disk([0.2, 0.001, 0.1], -Vec3::Y, 0.3)), None);
        assert_eq!(coincide(&floor, &disk([1.5, 0.0, 0.1], Vec3::Y, 0.3)), None);
        assert_eq!(coincide(&floor, &quad([-1.0, 0.0, -1.0], [0.0, 2.0, 0.0], [2.0, 0.0, 0.0])), None);
        // Quads sharing only an edge do not overlap over an area.
        assert_eq!(coincide(&floor, &quad([1.0, 0.0, -1.0], [0.0, 0.0, 2.0], [1.0, 0.0, 0.0])), None);
        let triangle =
            Polygon::new(vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.0, -0.5)])
                .unwrap();
        assert_eq!(coincide(&Shape::Polygon(Box::new(triangle)), &floor), Some("the same plane"));
    }

    #[test]
    fn the_same_sphere_or_cylinder_coincides_where_their_parts_overlap() {
        let s = |c: [f32; 3], r: f32| Shape::Sphere(Box::new(Sphere::new(Vec3::from(c), r)));
        assert_eq!(coincide(&s([1.0, 2.0, 3.0], 0.5), &s([1.0, 2.0, 3.0], 0.5)), Some("the same sphere"));
        assert_eq!(coincide(&s([1.0, 2.0, 3.0], 0.5), &s([1.0, 2.0, 3.0], 0.501)), None);
        assert_eq!(coincide(&s([1.0, 2.0, 3.0], 0.5), &s([1.0, 2.001, 3.0], 0.5)), None);
        // A cap below a level and the zone above it meet along a circle only.
        let zone = |lo: f32, hi: f32| Shape::Sphere(Box::new(Sphere::zone(Vec3::ZERO, 1.0, Vec3::Y, lo, hi)));
        assert_eq!(coincide(&zone(f32::NEG_INFINITY, -0.3), &zone(-0.3, 0.0)), None);
        assert_eq!(coincide(&zone(f32::NEG_INFINITY, -0.3), &zone(-0.5, 0.0)), Some("the same sphere"));
        // Cylinders on one axis line: overlapping heights coincide, stacked ones do not.
        let wall = cylinder([0.0, 0.06, 0.0], 0.32, 0.84);
        assert_eq!(coincide(&wall, &cylinder([0.0, 0.06, 0.0], 0.32, 0.5)), Some("the same cylinder"));
        assert_eq!(
            coincide(&cylinder([0.0, 0.06, 0.0], 0.32, 0.54), &cylinder([0.0, 0.6, 0.0], 0.32, 0.3)),
            None
        );
        assert_eq!(coincide(&wall, &cylinder([0.0, 0.06, 0.0], 0.3, 0.5)), None);
        assert_eq!(coincide(&wall, &cylinder([0.01, 0.06, 0.0], 0.32, 0.5)), None);
        // An upside-down cylinder over the same stretch.
        let down = Shape::Cylinder(Box::new(Cylinder::new(Vec3::new(0.0, 0.5, 0.0), -Vec3::Y, 0.32, 0.2)));
        assert_eq!(coincide(&wall, &down), Some("the same cylinder"));
        // Different kinds never coincide.
        assert_eq!(coincide(&wall, &s([0.0, 0.0, 0.0], 0.32)), None);
    }
}
