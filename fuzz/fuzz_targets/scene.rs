//! Fuzz target: parse and compile arbitrary scene text, then look at what `vitrum info` shows
//! (light powers and the environment's mean radiance, effects, BVH statistics) and trace a few
//! camera rays through the BVH. Bad input must come back as a `SceneError` (the CLI's exit code
//! 2), never as a panic, an overflow, an unbounded allocation or a hang. Nothing is rendered.

#![no_main]

use glam::Vec2;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let scene = match vitrum::scene::load_str(text, "fuzz.toml", None) {
        Ok(scene) => scene,
        Err(e) => {
            // The message every bad input ends in names its position (TOML syntax errors and
            // field errors alike).
            let message = e.to_string();
            assert!(message.starts_with("fuzz.toml:"), "{message}");
            return;
        }
    };
    // What `vitrum info` computes and prints.
    for light in &scene.lights {
        let _ = light.strength();
        let _ = format!("{light:?}");
    }
    for m in &scene.materials {
        let _ = format!("{:?}", m.bsdf);
    }
    for u in &scene.effects.0 {
        let _ = format!("{}: {}", u.effect, u.reason);
    }
    let _ = format!("{:?}", scene.bvh_stats);
    let _ = scene.warnings.len();
    // The render settings a render would start from.
    let _ = vitrum::render::RenderOptions::from_scene(&scene, scene.settings.spp);
    // A few camera rays through the BVH: traversal must not panic on any compiled scene.
    let camera = &scene.camera;
    let (w, h) = (camera.width as f32, camera.height as f32);
    for film in [Vec2::new(0.5 * w, 0.5 * h), Vec2::new(0.0, 0.0), Vec2::new(w, h)] {
        let ray = camera.generate_ray(film);
        if let Some(hit) = scene.intersect(&ray, f32::INFINITY) {
            let _ = scene.material_of(hit.primitive);
            let _ = scene.light_of(hit.primitive);
        }
    }
});
