//! The embedding example as a test: a host with its own device draws a floor, then
//! records peeltrim's CSG into the same depth buffer (`examples/embed.rs`), with
//! the validation layer on. Both depth conventions, one after the other (the
//! example's message log is process-wide).

#[allow(dead_code)]
#[path = "../examples/embed.rs"]
mod example;

#[test]
fn host_floor_and_csg_occlude_each_other_like_the_reference_composite() {
    for reversed_z in [false, true] {
        // The host creates, uses and destroys its own validated instance and device
        // outside peeltrim: nothing else in this process may call through the
        // validation layer meanwhile (`vk::layer_lock`).
        let only = peeltrim::vk::layer_lock::exclusive();
        let r = example::run([160, 120], reversed_z).expect("the host frame runs");
        drop(only);
        assert!(
            r.validation.is_empty(),
            "reversed_z={reversed_z}: validation:\n{}",
            r.validation.join("\n")
        );
        // Both ways of occlusion occur in this view, and each is drawn as the
        // reference composite says.
        assert!(r.floor_hides_csg > 200, "{r:?}");
        assert!(r.csg_hides_floor > 200, "{r:?}");
        assert!(
            r.floor_hides_csg_ok as f64 >= 0.9995 * r.floor_hides_csg as f64,
            "{r:?}"
        );
        assert!(
            r.csg_hides_floor_ok as f64 >= 0.9995 * r.csg_hides_floor as f64,
            "{r:?}"
        );
        assert!(
            r.interior_match() >= 0.9995,
            "reversed_z={reversed_z}: {r:?}"
        );
    }
}
