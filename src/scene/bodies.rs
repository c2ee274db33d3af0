//! Composite bodies expanded into closed, watertight sets of analytic surfaces.
//!
//! Every surface of a body is paired with a flag saying whether it uses the body's interface
//! as written (`false`: the normal points out of the material, into the outside medium) or
//! swapped (`true`: the normal points *into* the material, as on the inner wall of a hollow
//! sphere, where the outside of the surface is glass and the inside is air).

use crate::geometry::{Cylinder, Disk, Shape, Sphere};
use glam::Vec3;

/// A surface of an expanded body and whether its interface is swapped.
pub type BodySurface = (Shape, bool);

/// A finite cylinder: the wall plus, when `caps`, a bottom disk (normal −axis) and a top disk.
pub fn cylinder(base: Vec3, axis: Vec3, radius: f32, height: f32, caps: bool) -> Vec<BodySurface> {
    let mut s = vec![(Shape::Cylinder(Box::new(Cylinder::new(base, axis, radius, height))), false)];
    if caps {
        s.push((Shape::Disk(Box::new(Disk::new(base, -axis, radius, 0.0))), false));
        s.push((Shape::Disk(Box::new(Disk::new(base + axis * height, axis, radius, 0.0))), false));
    }
    s
}

/// A hollow sphere: the outer sphere as written, the inner one with the interface swapped.
pub fn hollow_sphere(center: Vec3, radius: f32, inner_radius: f32) -> Vec<BodySurface> {
    vec![
        (Shape::Sphere(Box::new(Sphere::new(center, radius))), false),
        (Shape::Sphere(Box::new(Sphere::new(center, inner_radius))), true),
    ]
}

/// A hemispherical bowl opening along `axis`: outer and inner hemispheres below the rim plane
/// through `center`, joined by a flat annulus (the rim) facing `axis`.
pub fn bowl(center: Vec3, axis: Vec3, radius: f32, thickness: f32) -> Vec<BodySurface> {
    let inner = radius - thickness;
    vec![
        (Shape::Sphere(Box::new(Sphere::clipped(center, radius, axis, 0.0))), false),
        (Shape::Sphere(Box::new(Sphere::clipped(center, inner, axis, 0.0))), true),
        (Shape::Disk(Box::new(Disk::new(center, axis, radius, inner))), false),
    ]
}

/// A drinking glass standing on `base`, open towards `axis`: outer wall and bottom, a solid
/// base of thickness `bottom`, an inner wall and cavity floor, and the rim annulus.
pub fn drinking_glass(
    base: Vec3,
    axis: Vec3,
    radius: f32,
    height: f32,
    wall: f32,
    bottom: f32,
) -> Vec<BodySurface> {
    let inner = radius - wall;
    let floor = base + axis * bottom;
    vec![
        (Shape::Cylinder(Box::new(Cylinder::new(base, axis, radius, height))), false),
        (Shape::Disk(Box::new(Disk::new(base, -axis, radius, 0.0))), false),
        (Shape::Cylinder(Box::new(Cylinder::new(floor, axis, inner, height - bottom))), true),
        (Shape::Disk(Box::new(Disk::new(floor, axis, inner, 0.0))), false),
        (Shape::Disk(Box::new(Disk::new(base + axis * height, axis, radius, inner))), false),
    ]
}
