//! Image files of a few hundred bytes whose headers declare more pixels than vitrum reads
//! (`vitrum::image::limits::MAX_IMAGE_PIXELS`), and vitrum run in an address space far too small
//! for those pixels: only a refusal before allocating can answer there.

use std::path::Path;
use std::process::{Command, Output};
use vitrum::image::limits::MAX_IMAGE_PIXELS;
use vitrum::image::Image;

/// The size the test files declare: the environment map of the bug report, 288 M pixels
/// (3.4 GB as f32 RGB), that aborted vitrum under a 6 GB memory limit.
pub const DECLARED: (u32, u32) = (24000, 12000);

/// The address space vitrum runs in, in KiB (`ulimit -v`): room for the program, not for
/// the pixels of [`DECLARED`].
const ADDRESS_SPACE_KIB: u32 = 400_000;

/// Overwrite the `box2i` attribute `name` of the EXR file `bytes` with the window from (0, 0)
/// of `width` × `height` pixels.
fn set_window(bytes: &mut [u8], name: &str, width: u32, height: u32) {
    let key = [name.as_bytes(), b"\0box2i\0", &16u32.to_le_bytes()].concat();
    let at = bytes.windows(key.len()).position(|w| w == key).expect("the window attribute") + key.len();
    let corners = [0, 0, width as i32 - 1, height as i32 - 1];
    for (slot, v) in bytes[at..at + 16].chunks_exact_mut(4).zip(corners) {
        slot.copy_from_slice(&v.to_le_bytes());
    }
}

/// Write a 4 × 2 EXR at `path` whose header declares `width` × `height` pixels.
pub fn write_exr_declaring(path: &Path, width: u32, height: u32) {
    vitrum::output::exr::write_exr(path, &Image::new(4, 2), &Default::default()).unwrap();
    let mut bytes = std::fs::read(path).unwrap();
    set_window(&mut bytes, "dataWindow", width, height);
    set_window(&mut bytes, "displayWindow", width, height);
    std::fs::write(path, bytes).unwrap();
}

/// The CRC-32 (ISO-HDLC, as PNG chunks use) of `bytes`.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = u32::MAX;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// Write a 1 × 1 PNG at `path` whose header (IHDR, its CRC fixed) declares `width` × `height`.
pub fn write_png_declaring(path: &Path, width: u32, height: u32) {
    let mut bytes = Vec::new();
    image::RgbImage::new(1, 1)
        .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .unwrap();
    // The signature (8 bytes), IHDR's length (4) and type (4), then width and height.
    bytes[16..20].copy_from_slice(&width.to_be_bytes());
    bytes[20..24].copy_from_slice(&height.to_be_bytes());
    let crc = crc32(&bytes[12..29]);
    bytes[29..33].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(path, bytes).unwrap();
}

/// Run vitrum with `args` in `dir` within [`ADDRESS_SPACE_KIB`] of address space (without the
/// cap where the shell cannot set it).
pub fn vitrum_capped(dir: &Path, args: &[&str]) -> Output {
    let script = format!(r#"ulimit -v {ADDRESS_SPACE_KIB} 2>/dev/null; exec "$0" "$@""#);
    Command::new("sh")
        .current_dir(dir)
        .arg("-c")
        .arg(script)
        .arg(env!("CARGO_BIN_EXE_vitrum"))
        .args(args)
        .output()
        .expect("sh runs")
}

/// Assert that `out` is the refusal of `file` for declaring [`DECLARED`]: exit code 2, a
/// message naming the file, its size and the limit, no panic.
pub fn assert_refused_as_too_large(out: &Output, file: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{file}: {stderr}");
    let size = format!("{}x{}", DECLARED.0, DECLARED.1);
    for named in [file, &size, &MAX_IMAGE_PIXELS.to_string(), "limit"] {
        assert!(stderr.contains(named), "{file}: `{named}` is named: {stderr}");
    }
    assert!(!stderr.contains("panicked"), "{stderr}");
}
