//! Composite bodies expanded into closed, watertight sets of analytic surfaces.
//!
//! Every surface of a body is paired with the [`Interface`] it uses: the body's material as
//! written (the normal points out of the material, into the outside medium), swapped (the
//! normal points *into* the material, as on the inner wall of a hollow sphere, where the outside
//! of the surface is glass and the inside is air), or one of the interfaces of a liquid filling a
//! vessel (glass/liquid, liquid/glass, and the liquid's free surface, liquid/outside medium).

use crate::geometry::{Cylinder, Disk, Shape, Sphere};
use crate::material::{Bsdf, Material, Medium};
use glam::Vec3;

/// Which pair of media a surface of a body separates, in terms of the body's material (a
/// dielectric: its `inside` is the body's medium, its `outside` the surrounding one) and, for
/// filled vessels, the liquid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Interface {
    /// The material as written: body inside, surroundings outside.
    Material,
    /// The material seen from the other side: surroundings inside, body outside.
    Swapped,
    /// Body inside, liquid outside: the normal points out of the glass into the liquid.
    BodyLiquid,
    /// Liquid inside, body outside: the normal points out of the liquid into the glass.
    LiquidBody,
    /// Liquid inside, surroundings outside: the liquid's free surface.
    LiquidSurface,
}

/// A surface of an expanded body and the interface it uses.
pub type BodySurface = (Shape, Interface);

/// The liquid of a filled vessel: the name used in derived material names, and its medium.
#[derive(Clone, Debug, PartialEq)]
pub struct Liquid {
    /// `water`, `ethanol`, … or `liquid` for one given by its medium.
    pub name: String,
    /// Its index and absorption.
    pub medium: Medium,
}

impl Interface {
    /// The material of a surface with this interface on a body of material `body`, with
    /// `liquid` in it. Derived names: `glass (inner)`, `glass (water)` (glass/water),
    /// `glass (water, inner)` (water/glass), `glass (water surface)` (water/air). A liquid
    /// interface of a material that is not a dielectric, or without a liquid, is the material
    /// itself (the compiler refuses both before it gets here).
    pub fn material(self, body: &Material, liquid: Option<&Liquid>) -> Material {
        let (Bsdf::Dielectric { inside, outside, roughness, distribution }, Some(liquid)) =
            (&body.bsdf, liquid)
        else {
            return match self {
                Interface::Swapped => body.swapped_interface(),
                _ => body.clone(),
            };
        };
        let (inside, outside, roughness, suffix) = match self {
            Interface::Material => return body.clone(),
            Interface::Swapped => return body.swapped_interface(),
            Interface::BodyLiquid => (*inside, liquid.medium, *roughness, liquid.name.clone()),
            Interface::LiquidBody => (liquid.medium, *inside, *roughness, format!("{}, inner", liquid.name)),
            // A liquid's free surface is smooth, whatever the glass.
            Interface::LiquidSurface => (liquid.medium, *outside, 0.0, format!("{} surface", liquid.name)),
        };
        let bsdf = Bsdf::Dielectric { inside, outside, roughness, distribution: *distribution };
        Material { name: format!("{} ({suffix})", body.name), phong: Material::default_phong(&bsdf), bsdf }
    }
}

/// A finite cylinder: the wall plus, when `caps`, a bottom disk (normal −axis) and a top disk;
/// with `inward`, every normal turned the other way (Mitsuba's `flip_normals`).
pub fn cylinder(
    base: Vec3,
    axis: Vec3,
    radius: f32,
    height: f32,
    caps: bool,
    inward: bool,
) -> Vec<BodySurface> {
    capped(Cylinder::new(base, axis, radius, height), axis, base + axis * height, caps, inward)
}

/// A finite cylinder from `base` to `top`, kept as given ([`Cylinder::between`]), capped at
/// both when `caps`; with `inward`, every normal turned the other way.
pub fn cylinder_between(base: Vec3, top: Vec3, radius: f32, caps: bool, inward: bool) -> Vec<BodySurface> {
    let wall = Cylinder::between(base, top, radius);
    capped(wall, wall.axis(), top, caps, inward)
}

/// `wall`, plus when `caps` a disk at its base facing −`axis` and one at `top` facing `axis`;
/// with `inward`, the wall and the disks facing the other way.
fn capped(wall: Cylinder, axis: Vec3, top: Vec3, caps: bool, inward: bool) -> Vec<BodySurface> {
    let (base, radius) = (wall.base(), wall.radius());
    let mut s = vec![(Shape::Cylinder(Box::new(wall.facing_inwards(inward))), Interface::Material)];
    if caps {
        let out = if inward { -axis } else { axis };
        s.push((Shape::Disk(Box::new(Disk::new(base, -out, radius, 0.0))), Interface::Material));
        s.push((Shape::Disk(Box::new(Disk::new(top, out, radius, 0.0))), Interface::Material));
    }
    s
}

/// A hollow sphere: the outer sphere as written, the inner one with the interface swapped.
pub fn hollow_sphere(center: Vec3, radius: f32, inner_radius: f32) -> Vec<BodySurface> {
    vec![
        (Shape::Sphere(Box::new(Sphere::new(center, radius))), Interface::Material),
        (Shape::Sphere(Box::new(Sphere::new(center, inner_radius))), Interface::Swapped),
    ]
}

/// A hemispherical bowl opening along `axis`: outer and inner hemispheres below the rim plane
/// through `center`, joined by a flat annulus (the rim) facing `axis`.
///
/// With `fill = Some(d)` (`0 <= d < radius − thickness`) it holds a liquid up to the depth `d`
/// below the rim plane: the inner sphere is split there into the cap below (liquid/glass) and
/// the zone above (air/glass, absent when `d = 0`), and the liquid's surface is the disk where
/// the plane cuts the inner sphere (liquid/air).
pub fn bowl(center: Vec3, axis: Vec3, radius: f32, thickness: f32, fill: Option<f32>) -> Vec<BodySurface> {
    let inner = radius - thickness;
    let sphere = |r: f32, lo: f32, hi: f32| Shape::Sphere(Box::new(Sphere::zone(center, r, axis, lo, hi)));
    let mut s = vec![
        (sphere(radius, f32::NEG_INFINITY, 0.0), Interface::Material),
        (Shape::Disk(Box::new(Disk::new(center, axis, radius, inner))), Interface::Material),
    ];
    match fill {
        None => s.push((sphere(inner, f32::NEG_INFINITY, 0.0), Interface::Swapped)),
        Some(depth) => {
            s.push((sphere(inner, f32::NEG_INFINITY, -depth), Interface::LiquidBody));
            if depth > 0.0 {
                s.push((sphere(inner, -depth, 0.0), Interface::Swapped));
            }
            let level = Disk::new(center - axis * depth, axis, (inner * inner - depth * depth).sqrt(), 0.0);
            s.push((Shape::Disk(Box::new(level)), Interface::LiquidSurface));
        }
    }
    s
}

/// A drinking glass standing on `base`, open towards `axis`: outer wall and bottom, a solid
/// base of thickness `bottom`, an inner wall and cavity floor, and the rim annulus.
///
/// With `fill = Some(f)` (`0 < f <= height − bottom`) it holds a liquid up to the height `f`
/// above the cavity floor: the floor is glass/liquid, the inner wall is split at the liquid's
/// level into the wall below (liquid/glass) and the wall above (air/glass, absent when the glass
/// is full to the rim), and the liquid's surface is a disk of the inner radius (liquid/air).
pub fn drinking_glass(
    base: Vec3,
    axis: Vec3,
    [radius, height, wall, bottom]: [f32; 4],
    fill: Option<f32>,
) -> Vec<BodySurface> {
    let inner = radius - wall;
    let floor = base + axis * bottom;
    let cavity = height - bottom;
    let wall_piece = |from: Vec3, h: f32| Shape::Cylinder(Box::new(Cylinder::new(from, axis, inner, h)));
    let mut s = vec![
        (Shape::Cylinder(Box::new(Cylinder::new(base, axis, radius, height))), Interface::Material),
        (Shape::Disk(Box::new(Disk::new(base, -axis, radius, 0.0))), Interface::Material),
        (Shape::Disk(Box::new(Disk::new(base + axis * height, axis, radius, inner))), Interface::Material),
    ];
    let floor_disk = Shape::Disk(Box::new(Disk::new(floor, axis, inner, 0.0)));
    match fill {
        None => {
            s.push((floor_disk, Interface::Material));
            s.push((wall_piece(floor, cavity), Interface::Swapped));
        }
        Some(f) => {
            let level = base + axis * (bottom + f);
            s.push((floor_disk, Interface::BodyLiquid));
            s.push((wall_piece(floor, f), Interface::LiquidBody));
            s.push((Shape::Disk(Box::new(Disk::new(level, axis, inner, 0.0))), Interface::LiquidSurface));
            if f < cavity {
                s.push((wall_piece(level, cavity - f), Interface::Swapped));
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dispersion::Ior;

    fn glass() -> Material {
        let bsdf = Bsdf::Dielectric {
            inside: Medium::clear(1.52),
            outside: Medium::clear(1.0),
            roughness: 0.1,
            distribution: crate::conductor::Distribution::Ggx,
        };
        Material { name: "glass".into(), phong: Material::default_phong(&bsdf), bsdf }
    }

    fn media(m: &Material) -> (f32, f32, f32) {
        let Bsdf::Dielectric { inside, outside, roughness, .. } = m.bsdf else { panic!("{m:?}") };
        (inside.ior.nominal(), outside.ior.nominal(), roughness)
    }

    #[test]
    fn liquid_interfaces_pair_the_right_media() {
        let water = Liquid { name: "water".into(), medium: Medium::clear(1.333) };
        let g = glass();
        let of = |i: Interface| i.material(&g, Some(&water));
        assert_eq!(media(&of(Interface::Material)), (1.52, 1.0, 0.1));
        assert_eq!(media(&of(Interface::Swapped)), (1.0, 1.52, 0.1));
        assert_eq!(media(&of(Interface::BodyLiquid)), (1.52, 1.333, 0.1));
        assert_eq!(media(&of(Interface::LiquidBody)), (1.333, 1.52, 0.1));
        assert_eq!(media(&of(Interface::LiquidSurface)), (1.333, 1.0, 0.0));
        assert_eq!(of(Interface::BodyLiquid).name, "glass (water)");
        assert_eq!(of(Interface::LiquidBody).name, "glass (water, inner)");
        assert_eq!(of(Interface::LiquidSurface).name, "glass (water surface)");
        assert_eq!(Ior::Constant(1.333), water.medium.ior);
    }

    #[test]
    fn filled_bodies_split_the_inner_wall_at_the_level() {
        let surfaces = drinking_glass(Vec3::ZERO, Vec3::Y, [0.35, 0.9, 0.03, 0.06], Some(0.54));
        assert_eq!(surfaces.len(), 7);
        let walls: Vec<(f32, f32, Interface)> = surfaces
            .iter()
            .filter_map(|(s, i)| match s {
                Shape::Cylinder(c) if c.radius() < 0.35 => Some((c.base().y, c.height(), *i)),
                _ => None,
            })
            .collect();
        assert_eq!(walls.len(), 2);
        assert!(walls.contains(&(0.06, 0.54, Interface::LiquidBody)), "{walls:?}");
        let above = walls.iter().find(|w| w.2 == Interface::Swapped).unwrap();
        assert!((above.0 - 0.6).abs() < 1e-6 && (above.1 - 0.3).abs() < 1e-6, "{above:?}");
        // Full to the rim: no wall above the liquid.
        assert_eq!(drinking_glass(Vec3::ZERO, Vec3::Y, [0.35, 0.9, 0.03, 0.06], Some(0.84)).len(), 6);
        let bowl_surfaces = bowl(Vec3::ZERO, Vec3::Y, 0.5, 0.04, Some(0.15));
        assert_eq!(bowl_surfaces.len(), 5);
        // The liquid's surface closes the cap below the level exactly: its rim is on the sphere.
        let Some((Shape::Disk(d), _)) = bowl_surfaces.iter().find(|s| s.1 == Interface::LiquidSurface) else {
            panic!()
        };
        assert!((d.radius().hypot(0.15) - 0.46).abs() < 1e-6);
        assert_eq!(bowl(Vec3::ZERO, Vec3::Y, 0.5, 0.04, Some(0.0)).len(), 4);
    }
}
