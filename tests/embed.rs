//! The embedding example as a test: a host with its own device draws a floor, then
//! records peeltrim's CSG into the same depth buffer (`examples/embed.rs`), with
//! the validation layer on. Every host set-up of the example (colour formats
//! RGBA/BGRA, UNORM/SRGB; depth D32, D24S8, D32S8; standard and reversed Z; one
//! to three frames in flight; 4 samples per pixel, the host resolving), one
//! after the other (the example's message log is process-wide); then loop
//! counts guessed too low and too high, and formats the composite cannot
//! write.

use ash::vk::Format;
use peeltrim::vk::embed::HostPath;
use peeltrim::vk::DepthFormat;
use peeltrim::{Algo, LoopCounts};

#[allow(dead_code)]
#[path = "../examples/embed.rs"]
mod example;

/// The example host creates, uses and destroys its own validated instance and
/// device outside peeltrim: nothing else in this process may call through the
/// validation layer meanwhile (`vk::layer_lock`).
fn host_alone() -> impl Drop {
    peeltrim::vk::layer_lock::exclusive()
}

fn check(name: &str, r: &example::Report) {
    assert!(
        r.validation.is_empty(),
        "{name}: validation:\n{}",
        r.validation.join("\n")
    );
    // Both ways of occlusion occur in this view, and each is drawn as the
    // reference composite says.
    assert!(r.floor_hides_csg > 200, "{name}: {r:?}");
    assert!(r.csg_hides_floor > 200, "{name}: {r:?}");
    assert!(
        r.floor_hides_csg_ok as f64 >= 0.9995 * r.floor_hides_csg as f64,
        "{name}: {r:?}"
    );
    assert!(
        r.csg_hides_floor_ok as f64 >= 0.9995 * r.csg_hides_floor as f64,
        "{name}: {r:?}"
    );
    assert!(r.interior_match() >= 0.9995, "{name}: {r:?}");
}

#[test]
fn host_floor_and_csg_occlude_each_other_like_the_reference_composite() {
    let _only = host_alone();
    for (name, setup) in example::setups() {
        let r = example::run(&setup).unwrap_or_else(|e| panic!("{name}: {e}"));
        if let Some(why) = &r.skipped {
            // Only a multisampled host, on a device without the count (or
            // without gl_FragCoord.z at the sample: SwiftShader).
            assert!(setup.samples > 1, "{name}: {why}");
            assert!(why.contains("samples per pixel"), "{name}: {why}");
            eprintln!("note: {name}: not run: {why}");
            continue;
        }
        check(&name, &r);
        if setup.samples > 1 {
            // The host's floor hides the CSG per sample (the interior bars
            // above, at every sample), and the edges against it are
            // antialiased: the samples' mean, blended.
            assert!(r.floor_edges_antialiased(), "{name}: {r:?}");
            assert!(
                r.host_paths.iter().all(|p| *p == Some(HostPath::Direct)),
                "{name}: {r:?}"
            );
        }
    }
}

/// A multisampled host frame whose plan needs the composite (blister-paper
/// colours from its peel) is refused naming the reason, not drawn aliased.
#[test]
fn a_multisampled_host_refuses_the_composite_path() {
    let _only = host_alone();
    let setup = example::Setup {
        samples: 4,
        algo: Algo::BlisterPaper,
        ..example::Setup::new([64, 48], false)
    };
    match example::run(&setup) {
        Ok(r) => {
            let why = r.skipped.expect("refused, or skipped on this device");
            assert!(why.contains("samples per pixel"), "{why}");
        }
        Err(e) => {
            assert!(e.contains("4 samples per pixel"), "{e}");
            assert!(e.contains("samples 1"), "{e}");
        }
    }
}

/// A default host gets the direct path: every frame's final shade drawn
/// straight into its targets, no composite; its meshes, which no face can tie
/// with, at the output depth (no tie test, no texture copy), and with the
/// tie rule where peeltrim's depth is D24S8 (whose shade keeps the rule). A
/// plan without the depth-equal shade (`blister-paper` colours from its peel)
/// falls back to the composite, which reads the peel's depth texture. Each
/// image as right as the reference composite.
#[test]
fn default_hosts_get_the_direct_path_and_blister_paper_the_composite() {
    let _only = host_alone();
    let direct = example::Setup {
        frames: 2,
        ..example::Setup::new([160, 120], true)
    };
    let r = example::run(&direct).expect("runs");
    check("direct", &r);
    assert_eq!(r.host_paths, vec![Some(HostPath::Direct); 2], "{r:?}");
    // Depth-equal pieces where the profile allows them, else the rule.
    match depth_equal_shades() {
        true => assert!(r.shade_fixed_draws > 0 && r.shade_rule_draws == 0, "{r:?}"),
        false => assert!(r.shade_rule_draws > 0 && r.shade_fixed_draws == 0, "{r:?}"),
    }
    let rule = example::Setup {
        internal_depth: DepthFormat::D24S8,
        ..example::Setup::new([160, 120], false)
    };
    let r = example::run(&rule).expect("runs");
    check("tie rule", &r);
    assert_eq!(r.host_paths, vec![Some(HostPath::Direct)], "{r:?}");
    assert!(r.shade_rule_draws > 0 && r.shade_fixed_draws == 0, "{r:?}");
    for reversed_z in [false, true] {
        let paper = example::Setup {
            algo: Algo::BlisterPaper,
            ..example::Setup::new([160, 120], reversed_z)
        };
        let r = example::run(&paper).expect("runs");
        check("blister-paper", &r);
        assert_eq!(r.host_paths, vec![Some(HostPath::CompositePlan)], "{r:?}");
    }
}

/// A one-primitive product (the ball beside the box, half below the floor)
/// is one the standalone frame shades in its direct draw; the host path takes
/// the same decision and draws its depth-equal piece without the check of
/// the output depth (after the depth merge, which the box's four bites call
/// for; where the pieces write their own depth, every piece checks). The floor must still hide the ball's lower half and the
/// ball hide the floor behind it, as the reference composite says, in every
/// depth convention, with depth buffers that round (D24S8, D16) and an
/// `_SRGB` colour format (the decoding variant).
#[test]
fn a_host_floor_hides_a_directly_shaded_product_where_it_is_in_front() {
    let _only = host_alone();
    for (color_format, depth_format, reversed_z) in [
        (Format::R8G8B8A8_UNORM, Format::D32_SFLOAT, false),
        (Format::R8G8B8A8_UNORM, Format::D32_SFLOAT, true),
        (Format::B8G8R8A8_SRGB, Format::D24_UNORM_S8_UINT, true),
        (Format::R8G8B8A8_UNORM, Format::D16_UNORM, false),
    ] {
        // With the bites the pieces follow the merge (the ball alone would
        // have them write their depth, the fetch kept: see below), where
        // the box's pieces keep the check outside the bites too: drawn in
        // parts without it (`plan::cut_away`), they cost fewer pixels
        // written than the merge (the next test).
        let setup = example::Setup {
            ball: true,
            bites: true,
            uncut: false,
            color_format,
            depth_format,
            ..example::Setup::new([160, 120], reversed_z)
        };
        let name = format!("ball, {color_format:?}+{depth_format:?}, reversed {reversed_z}");
        let r = example::run(&setup).unwrap_or_else(|e| panic!("{name}: {e}"));
        check(&name, &r);
        assert_eq!(r.host_paths, vec![Some(HostPath::Direct)], "{name}: {r:?}");
        // The ball's piece took the decision; the box and its bites did not.
        // Where the profile allows no depth-equal shade, no piece takes it.
        if depth_equal_shades() {
            assert_eq!(r.direct_shade_draws, 1, "{name}: {r:?}");
            assert!(r.shade_fixed_draws >= 6, "{name}: {r:?}");
        } else {
            assert_eq!(
                r.direct_shade_draws + r.shade_fixed_draws,
                0,
                "{name}: {r:?}"
            );
        }
        assert_eq!(r.shade_written_draws, 0, "{name}: {r:?}");
    }
}

/// The depth-equal pieces either follow one depth merge or, where their
/// fragments are fewer than its pixels (`record::host::writes_depth`), write
/// their own depth with no merge: the box with one bite writes, and so does it
/// with the ball beside it; with four bites (three more subtracted balls in
/// the box's rectangle, whose back faces the merge turns away before their
/// shader) the merge comes first. The ball, a one-primitive product
/// (`plan::direct_shade`), writes its depth with no fetch of the output depth
/// (`Piece::WrittenDirect`: none of its faces lies nearer than it, so a
/// hidden fragment it writes is overwritten by the visible face's piece),
/// half below the floor. Either way the floor hides the CSG and the
/// CSG the floor as the reference composite says, in both depth conventions,
/// with depth buffers that round (D24S8, D16) and an `_SRGB` colour format
/// (the decoding variant).
#[test]
fn written_pieces_and_the_merge_each_meet_the_host_floor_like_the_reference() {
    let _only = host_alone();
    for (ball, bites, writes) in [
        (false, false, true),
        (true, false, true),
        (false, true, false),
    ] {
        for (color_format, depth_format, reversed_z) in [
            (Format::R8G8B8A8_UNORM, Format::D32_SFLOAT, false),
            (Format::B8G8R8A8_SRGB, Format::D24_UNORM_S8_UINT, true),
            (Format::R8G8B8A8_UNORM, Format::D16_UNORM, false),
        ] {
            let setup = example::Setup {
                ball,
                bites,
                color_format,
                depth_format,
                ..example::Setup::new([160, 120], reversed_z)
            };
            let name = format!(
                "ball {ball}, bites {bites}, {color_format:?}+{depth_format:?}, reversed {reversed_z}"
            );
            let r = example::run(&setup).unwrap_or_else(|e| panic!("{name}: {e}"));
            check(&name, &r);
            assert_eq!(r.host_paths, vec![Some(HostPath::Direct)], "{name}: {r:?}");
            if !depth_equal_shades() {
                // Every piece keeps the rule: none writes, none is direct.
                let c = [
                    r.shade_fixed_draws,
                    r.shade_written_draws,
                    r.direct_shade_draws,
                ];
                assert_eq!(c, [0; 3], "{name}: {r:?}");
                continue;
            }
            assert!(r.shade_fixed_draws >= 2, "{name}: {r:?}");
            let written = if writes { r.shade_fixed_draws } else { 0 };
            assert_eq!(r.shade_written_draws, written, "{name}: {r:?}");
            // After the merge no piece is split at its cutters (`Piece::WrittenUncut`
            // is for written pieces only).
            if !writes {
                assert_eq!(r.shade_uncut_draws, 0, "{name}: {r:?}");
            }
            // The ball's piece took the direct decision on either path.
            assert_eq!(r.direct_shade_draws, ball as u64, "{name}: {r:?}");
        }
    }
}

/// The example's box with four pits, Goldfeather and SCS, on D32 standard and
/// reversed, D24S8 with `_SRGB` and D16, at 480×360: large enough that a
/// free piece pays for its draw (`cut_away::PIECE_PIXELS`). With a name each.
fn drilled_setups() -> Vec<(String, example::Setup)> {
    let formats = [
        (Format::R8G8B8A8_UNORM, Format::D32_SFLOAT, false),
        (Format::R8G8B8A8_UNORM, Format::D32_SFLOAT, true),
        (Format::B8G8R8A8_SRGB, Format::D24_UNORM_S8_UINT, true),
        (Format::R8G8B8A8_UNORM, Format::D16_UNORM, false),
    ];
    [Algo::Goldfeather, Algo::Scs]
        .into_iter()
        .flat_map(|algo| formats.map(|f| (algo, f)))
        .map(|(algo, (color_format, depth_format, reversed_z))| {
            let name = format!("{algo}, {color_format:?}+{depth_format:?}, reversed {reversed_z}");
            let setup = example::Setup {
                drilled: true,
                algo,
                color_format,
                depth_format,
                ..example::Setup::new([480, 360], reversed_z)
            };
            (name, setup)
        })
        .collect()
}

/// `setup` run and checked against the reference composite, drawn on the
/// direct path (no composite).
fn run_direct(name: &str, setup: &example::Setup) -> example::Report {
    let r = example::run(setup).unwrap_or_else(|e| panic!("{name}: {e}"));
    check(name, &r);
    assert_eq!(r.host_paths, vec![Some(HostPath::Direct)], "{name}: {r:?}");
    r
}

/// `other`, run, checked against the reference composite and with the very
/// image of `r` (the same set-up with one switch flipped).
fn same_image(name: &str, r: &example::Report, other: &example::Setup) -> example::Report {
    let k = run_direct(name, other);
    assert_eq!(r.image.0.len(), k.image.0.len(), "{name}");
    let differ = r
        .image
        .0
        .iter()
        .zip(&k.image.0)
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(differ, 0, "{name}: {differ} pixels differ");
    k
}

/// The drilled box (`examples/embed.rs` `Setup::drilled`: four small pits
/// in its faces towards the eye, `m0 - m1 - … - m4`): the box is the only
/// positive literal of its product, so outside the pits' screen rectangles
/// none of its front faces lies nearer than the output depth and its
/// depth-equal piece is drawn there without the check of the output depth
/// (`plan::cut_away`, `Piece::WrittenUncut`), the rest of it with the check.
/// The image is the one with every check kept, pixel for pixel, and both
/// meet the host's floor as the reference composite says; Goldfeather and
/// SCS (the two algorithms the argument is made for), both depth
/// conventions, depth buffers that round (D24S8, D16), an `_SRGB` colour
/// format.
#[test]
fn pieces_outside_their_cutters_skip_the_fetch_and_change_no_pixel() {
    let _only = host_alone();
    for (name, setup) in drilled_setups() {
        let r = run_direct(&name, &setup);
        // Only depth-equal pieces are cut (none where the profile keeps the
        // rule).
        let shades = depth_equal_shades();
        assert_eq!(r.shade_uncut_draws > 0, shades, "{name}: {r:?}");
        // With no merge: the parts outside the pits cost nothing.
        assert_eq!(r.shade_written_draws, r.shade_fixed_draws, "{name}: {r:?}");
        let kept = example::Setup {
            uncut: false,
            ..setup.clone()
        };
        let k = same_image(&format!("{name}, kept"), &r, &kept);
        assert_eq!(k.shade_uncut_draws, 0, "{name}: {k:?}");
    }
}

/// The written final shade draws the pits' insides after the box's faces,
/// strictly tested (`record::host::insides_last`), with and without the
/// fetch-free parts outside the pits: the image the reference composite
/// says.
#[test]
fn insides_drawn_last_change_no_pixel() {
    let _only = host_alone();
    for (name, drilled) in drilled_setups() {
        for uncut in [true, false] {
            let name = format!("{name}, uncut {uncut}");
            let setup = example::Setup {
                uncut,
                ..drilled.clone()
            };
            let r = run_direct(&name, &setup);
            // The four pits' insides. With the cutters known, each is drawn
            // where it can be seen: the boxes of the pits on the top and the
            // right touch, so each of those two is drawn through both their
            // openings (6 pieces).
            // None where the profile keeps the rule on every piece.
            let pieces = match (depth_equal_shades(), uncut) {
                (false, _) => 0,
                (true, true) => 6,
                (true, false) => 4,
            };
            assert_eq!(r.shade_insides_last, pieces, "{name}: {r:?}");
        }
    }
}

/// The written final shade cut to the openings: the box's check of the
/// output depth only over its front faces inside the pits' boxes
/// (`plan::cut_away::facing_parts`), and each pit's inside drawn only where
/// it can be seen through an opening (`CutAway::inside_holes`). The image the
/// reference composite says; the insides lose pixels.
#[test]
fn the_final_shade_cut_to_the_openings_changes_no_pixel() {
    let _only = host_alone();
    for (name, setup) in drilled_setups() {
        let r = run_direct(&name, &setup);
        // The insides are depth-equal pieces: none where the profile keeps
        // the rule.
        let shades = depth_equal_shades();
        assert_eq!(r.shade_insides_cut_pixels > 0, shades, "{name}: {r:?}");
    }
}

#[test]
fn loop_counts_guessed_too_low_are_doubled_by_the_ring_and_too_high_are_shrunk() {
    let _only = host_alone();
    // Blister peels every face in one loop (the convex box and ball give
    // Goldfeather none). Too low: one head. With 2 frames in flight a frame's
    // counts are read 3 frames later and doubled; the last frame has grown
    // counts and a right image.
    let low = example::Setup {
        frames_in_flight: 2,
        frames: 12,
        loop_counts: LoopCounts::Fixed(1),
        algo: Algo::Blister,
        ..example::Setup::new([160, 120], true)
    };
    let r = example::run(&low).expect("runs");
    check("too low", &r);
    assert!(
        !r.first_counts.is_empty() && r.first_counts.iter().all(|&c| c == 1),
        "{r:?}"
    );
    assert!(
        r.last_counts
            .iter()
            .zip(&r.first_counts)
            .any(|(l, f)| l > f),
        "{r:?}"
    );
    // Too high: the very first frame is already right (empty heads change
    // nothing), and the counts shrink once its slot comes round.
    for frames in [1, 5] {
        let high = example::Setup {
            frames_in_flight: 2,
            frames,
            loop_counts: LoopCounts::Fixed(12),
            algo: Algo::Blister,
            ..example::Setup::new([160, 120], false)
        };
        let r = example::run(&high).expect("runs");
        check("too high", &r);
        if frames > 3 {
            assert!(
                r.last_counts
                    .iter()
                    .zip(&r.first_counts)
                    .all(|(l, f)| l < f),
                "{r:?}"
            );
        }
    }
    // The default, estimated on the CPU: right from the first frame here.
    let est = example::Setup {
        algo: Algo::Blister,
        ..example::Setup::new([160, 120], false)
    };
    let r = example::run(&est).expect("runs");
    check("estimate", &r);
    assert!(r.first_counts.iter().all(|&c| c >= 5), "{r:?}");
}

#[test]
fn formats_the_composite_cannot_write_are_a_typed_error_before_any_command() {
    let _only = host_alone();
    for (color, depth, which) in [
        (Format::R8G8B8A8_UINT, Format::D32_SFLOAT, "colour"),
        (Format::R8_UNORM, Format::D32_SFLOAT, "colour"),
        (Format::R8G8B8A8_UNORM, Format::S8_UINT, "depth"),
        (Format::R8G8B8A8_UNORM, Format::R32_SFLOAT, "depth"),
    ] {
        let e = example::record_with_formats(color, depth)
            .unwrap_or_else(|e| panic!("{color:?}+{depth:?}: {e}"))
            .unwrap_or_else(|| panic!("{color:?}+{depth:?} accepted"));
        assert!(e.contains(which) && e.contains("use one of"), "{e}");
    }
}

/// Whether the test device's profile (`PEELTRIM_DEVICE_PROFILE` applied) shades
/// the final products as depth-equal draws on the examples' D32S8 images.
fn depth_equal_shades() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| {
        let ctx = peeltrim::vk::Context::new(&peeltrim::vk::ContextDesc {
            device: peeltrim::vk::DeviceChoice::Cpu,
            validation: false,
        })
        .expect("a Vulkan device");
        ctx.profile()
            .depth_equal_shades(peeltrim::vk::DepthFormat::D32S8)
    })
}
