//! Fuzz target, the XML twin of `scene`: arbitrary text read as a Mitsuba scene
//! (`vitrum::scene::mitsuba::load_str`: the XML reader, the translation into vitrum's TOML and
//! the compile step), strictly or leniently as the first byte says, then looked at as `scene`
//! does. Bad input must come back as a `SceneError` naming its position in `fuzz.xml`, never as
//! a panic, an overflow, an unbounded allocation or a hang. Text without a file includes nothing.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else { return };
    let Ok(text) = std::str::from_utf8(rest) else { return };
    let lenient = mode & 1 == 1;
    match vitrum::scene::mitsuba::load_str(text, "fuzz.xml", None, lenient) {
        Ok(scene) => {
            for light in &scene.lights {
                let _ = light.strength();
            }
            let _ = format!("{:?}", scene.bvh_stats);
            let _ = vitrum::render::RenderOptions::from_scene(&scene, scene.settings.spp);
        }
        Err(e) => {
            let message = e.to_string();
            assert!(message.starts_with("fuzz.xml:"), "{message}");
        }
    }
});
