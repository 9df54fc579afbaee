//! Device limits: frames the device cannot hold are refused before any
//! image is created, naming the device's figure and the way out.

use super::{assert_clean, context};
use peeltrim::vk::VkError;

#[test]
fn frames_past_the_device_limits_are_refused_clearly() {
    let ctx = context();
    let max = ctx.max_image_side();
    assert!(max >= 4096, "maxImageDimension2D {max}");
    ctx.check_frame_size(64, 48, peeltrim_cli::render::DEVICE_BYTES_PER_PIXEL)
        .expect("a small frame fits");
    let e = ctx
        .check_frame_size(max + 1, 16, 4)
        .expect_err("a side past maxImageDimension2D");
    assert!(matches!(e, VkError::FrameTooLarge(_)));
    let msg = e.to_string();
    assert!(
        msg.contains(&format!("{}x16", max + 1))
            && msg.contains(&format!("{max} pixels"))
            && msg.contains("maxImageDimension2D")
            && msg.contains("smaller --size"),
        "{msg}"
    );
    let heap = ctx.device_local_bytes();
    assert!(heap > 0);
    // Images larger than the device's memory: bytes per pixel chosen past the heap.
    let per_pixel = heap / (max as u64 * max as u64) + 1;
    let msg = ctx
        .check_frame_size(max, max, per_pixel)
        .expect_err("images past the device-local heap")
        .to_string();
    assert!(
        msg.contains("of device memory") && msg.contains("smaller --size"),
        "{msg}"
    );
    assert_clean(&ctx);
}
