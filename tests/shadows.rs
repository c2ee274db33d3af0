//! Shadow rays through glass: the transmittance behind a glass sphere against the analytic
//! straight-through value T(θ)² (two Fresnel crossings at the same angle), with no black rim.

use glam::{Vec2, Vec3};
use vitrum::geometry::SurfaceHit;
use vitrum::lighting::{transmittance, ShadowMode, ShadowRays};
use vitrum::optics::fresnel_dielectric;
use vitrum::scene::load_str;
use vitrum::stats::RayCounts;

const SPHERE: &str = r#"
[camera]
position = [0.0, 5.0, 5.0]
look_at = [0.0, 0.0, 0.0]
resolution = [8, 8]
[materials.glass]
type = "dielectric"
ior = 1.5
[[objects]]
shape = "sphere"
center = [0.0, 2.0, 0.0]
radius = 1.0
material = "glass"
"#;

#[test]
fn glass_sphere_shadow_follows_the_two_crossing_fresnel_profile() {
    let scene = load_str(SPHERE, "sphere", None).unwrap();
    let shadow = ShadowRays {
        mode: ShadowMode::ThroughGlass { reflectance: None },
        channels: vitrum::spectrum::Channels::Rgb,
        time: 0.0,
    };
    let mut rays = RayCounts::default();
    // Floor points at impact parameter b below the sphere, light straight above (far away).
    for k in 0..100 {
        let b = k as f32 / 100.0;
        let from = SurfaceHit {
            t: 1.0,
            p: Vec3::new(b, 0.0, 0.0),
            n: Vec3::Y,
            shading_n: Vec3::Y,
            uv: Vec2::ZERO,
            p_error: 1e-6,
        };
        let t = transmittance(&scene, &from, Vec3::new(b, 1e4, 0.0), None, shadow, &mut rays);
        let cos = (1.0 - b * b).sqrt();
        let single = 1.0 - fresnel_dielectric(cos, 1.5);
        let expected = single * single;
        assert!((t.x - expected).abs() < 1e-4, "b = {b}: {} vs {expected}", t.x);
        assert!(t.x > 0.0, "black rim at b = {b}");
    }
    // Outside the silhouette the light is unobstructed.
    let from = SurfaceHit {
        t: 1.0,
        p: Vec3::new(1.01, 0.0, 0.0),
        n: Vec3::Y,
        shading_n: Vec3::Y,
        uv: Vec2::ZERO,
        p_error: 1e-6,
    };
    assert_eq!(transmittance(&scene, &from, Vec3::new(1.01, 1e4, 0.0), None, shadow, &mut rays), Vec3::ONE);
}
