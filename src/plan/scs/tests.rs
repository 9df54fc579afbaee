//! Unit tests of the SCS plan builder (module documentation of [`super`]).
use super::*;
use crate::plan::goldfeather::CLIP_EPS;
use crate::plan::print::count;
use crate::scene::fixtures::block_minus_spheres;

/// Boxes along x: 1–2 overlap, 2–3 touch, 4 and 5 stand alone; 6–7 overlap.
fn row_of_boxes() -> Prepared {
    use crate::scene::fixtures::ExprBuilder;
    use crate::scene::Aabb;
    use glam::DVec3;
    let spans = [
        (-10.0, 10.0),
        (0.0, 1.5),
        (1.0, 2.0),
        (2.0, 3.0),
        (4.0, 5.0),
        (6.0, 7.0),
        (8.0, 9.0),
        (8.5, 9.5),
    ];
    let bounds = spans
        .iter()
        .map(|&(a, b)| Aabb {
            min: DVec3::new(a, -1.0, -1.0),
            max: DVec3::new(b, 1.0, 1.0),
        })
        .collect();
    let mut e = ExprBuilder::default();
    let mut acc = e.leaf(0);
    for i in 1..spans.len() as u32 {
        let l = e.leaf(i);
        acc = e.diff(acc, l);
    }
    let mut prep = Prepared::from_parts(e.build(acc), vec![12; spans.len()], bounds);
    prep.mesh_convex = vec![true; spans.len()];
    prep
}

#[test]
fn sequence_repeats_only_overlapping_cutters() {
    let prep = row_of_boxes();
    let lit = |prim| Lit {
        prim,
        negated: true,
    };
    let ys: Vec<Lit> = (1..8).map(lit).collect();
    let seq = sequence(&ys, &prep);
    assert_eq!(seq.once, vec![lit(4), lit(5)]);
    // Groups {1, 2, 3} and {6, 7}, interleaved, three rounds.
    assert_eq!(seq.max_rounds, 3);
    let mut rounds = seq.rounds.clone();
    rounds.sort_by_key(|l| l.prim);
    assert_eq!(rounds, vec![lit(1), lit(2), lit(3), lit(6), lit(7)]);
    // A batch never holds two overlapping cutters: the round 1, 6, 2, 7, 3 is
    // cut wherever the next one meets one already in the batch.
    let at = Subtraction {
        prep: &prep,
        region: &Region::Intersection(vec![0]),
        eps: CLIP_EPS,
        count: true,
        ds: SURFACE,
    };
    let steps = subtract(&seq.rounds, at);
    let mut batch: Vec<MeshId> = Vec::new();
    for s in &steps {
        let Step::Draw(d) = s else { continue };
        let Geometry::Mesh(m) = d.geometry else {
            panic!("mesh draws only")
        };
        if d.cull == Cull::None {
            if batch
                .last()
                .is_some_and(|_| d.stencil.unwrap().write_mask == 1)
            {
                batch.clear();
            }
            for &b in &batch {
                let (x, y) = (&prep.mesh_bounds[b as usize], &prep.mesh_bounds[m as usize]);
                assert!(
                    crate::plan::cst::disjoint(x, y),
                    "{b} and {m} share a batch"
                );
            }
            batch.push(m);
        } else {
            assert!(d.count_samples, "the rounds' exits are counted");
        }
    }
}

#[test]
fn the_plan_repeats_the_groups_in_a_bounded_loop() {
    let prep = row_of_boxes();
    let built = plan(&prep, &ProductOptions::default()).unwrap();
    let loops: Vec<&Loop> = built.loops().collect();
    assert_eq!(loops.len(), 1);
    assert_eq!(loops[0].max_iterations, 3);
    assert!(loops[0].tail.is_empty());
    assert_eq!(fallback_warning(&prep), None);
    // A non-convex cutter sends the product to Goldfeather's steps, said once.
    let mut nc = prep.clone();
    nc.mesh_convex[3] = false;
    let w = fallback_warning(&nc).expect("a warning");
    assert!(w.contains("non-convex primitive(s) 4"), "{w}");
    let built = plan(&nc, &ProductOptions::default()).unwrap();
    assert!(!built
        .steps
        .iter()
        .any(|s| matches!(s, Step::Pass(p) if p == "scs-front")));
}

/// The draws of the pass named `name` (the first such pass).
fn pass_draws<'a>(steps: &'a [Step], name: &str) -> Vec<&'a Draw> {
    steps
        .iter()
        .skip_while(|s| !matches!(s, Step::Pass(p) if p == name))
        .skip(1)
        .take_while(|s| !matches!(s, Step::Pass(_)))
        .filter_map(|s| match s {
            Step::Draw(d) => Some(d),
            _ => None,
        })
        .collect()
}

/// `row_of_boxes`' boxes under `(0 − 4 − 5) ∪ (6 − 7)`: two products of
/// one positive primitive each.
fn two_products() -> Prepared {
    use crate::scene::fixtures::ExprBuilder;
    let boxes = row_of_boxes().mesh_bounds;
    let mut e = ExprBuilder::default();
    let l: Vec<u32> = (0..8).map(|i| e.leaf(i)).collect();
    let a = e.diff(l[0], l[4]);
    let a = e.diff(a, l[5]);
    let b = e.diff(l[6], l[7]);
    let root = e.union(a, b);
    let mut prep = Prepared::from_parts(e.build(root), vec![12; 8], boxes);
    prep.mesh_convex = vec![true; 8];
    prep
}

#[test]
fn the_first_product_is_clipped_by_back_faces_in_the_output() {
    let prep = two_products();
    let built = plan(&prep, &ProductOptions::default()).unwrap();
    // The first product: no surface image, its `z` kept in the output.
    let first: Vec<&Step> = built
        .steps
        .iter()
        .skip_while(|s| !matches!(s, Step::Pass(p) if p == "scs-front"))
        .skip(1)
        .take_while(|s| !matches!(s, Step::Pass(p) if p == "scs-front"))
        .collect();
    assert!(first
        .iter()
        .all(|s| !matches!(s, Step::Pass(p) if p == "merge")));
    assert!(!first
        .iter()
        .any(|s| matches!(s, Step::Clear(Clear::DepthStencil { .. }))));
    let front = pass_draws(&built.steps, "scs-front");
    assert_eq!(
        (&front[0].geometry, front[0].ds, front[0].depth.compare),
        (&Geometry::Mesh(0), OUTPUT, CompareOp::Less)
    );
    // Every exit moves `z` in the depth-stencil image too (the tie-free
    // parity draws test it there).
    let exits: Vec<&Draw> = pass_draws(&built.steps, "subtract")
        .into_iter()
        .filter(|d| d.cull == Cull::Front)
        .collect();
    assert_eq!(exits.len(), 2);
    // They test `Greater` (subtract's front-face parity) in the output too.
    assert!(exits.iter().all(|d| d.ds == OUTPUT
        && d.depth.write
        && d.depth.compare == CompareOp::Greater
        && d.fragment == Fragment::WriteDepth { out: SURF }));
    // The clip: box 0's back faces count where they lie behind `z`, and
    // one sweep of the output sets far where the count is not 1, over
    // box 0's footprint: its front faces, culled as its front draw.
    let clip = pass_draws(&built.steps, "clip");
    assert_eq!(clip.len(), 2);
    let (c, sweep) = (clip[0], clip[1]);
    assert_eq!(
        (&c.geometry, c.cull, c.ds, c.depth.write),
        (&Geometry::Mesh(0), Cull::Front, OUTPUT, false)
    );
    assert_eq!(
        c.fragment,
        Fragment::BehindThan {
            tex: SURF,
            eps: CLIP_EPS
        }
    );
    let st = c.stencil.unwrap();
    assert_eq!(
        (st.front.pass, st.write_mask),
        (StencilOp::IncrementAndClamp, 1)
    );
    assert_eq!(
        sweep.geometry,
        Geometry::Footprint {
            mesh: 0,
            depth: goldfeather::FAR
        }
    );
    // Both only where an exit may have moved `z`: box 0's rectangle cut
    // to its cutters' (elsewhere `z` is box 0's front face, inside it).
    let moved = Scissor::Within {
        meshes: vec![0],
        within: vec![4, 5],
    };
    assert_eq!(
        (&c.scissor, &sweep.scissor, sweep.cull),
        (&moved, &moved, front[0].cull)
    );
    assert_eq!((sweep.ds, &sweep.fragment), (OUTPUT, &Fragment::None));
    assert_eq!(sweep.depth.compare, CompareOp::Always);
    let st = sweep.stencil.unwrap();
    assert_eq!(
        (
            st.front.compare,
            st.reference,
            st.compare_mask,
            st.write_mask
        ),
        (CompareOp::NotEqual, 1, 1, 1)
    );
    // A pixel its front faces covered twice stays kept: a failing test
    // keeps the count; a rejected pixel's count is cleared.
    assert_eq!(
        (st.front.fail, st.back.fail, st.front.pass),
        (StencilOp::Keep, StencilOp::Keep, StencilOp::Zero)
    );
    let twice = |count: u8| {
        let once = crate::plan::stencil::simulate(&st, count, true);
        crate::plan::stencil::simulate(&st, once, true)
    };
    assert_eq!(twice(1), 1);
    assert_eq!(twice(0), 0);
    // The second product: in the surface image, then one draw of box 6's
    // back faces carries `z` into the output where they lie behind it.
    let merge = pass_draws(&built.steps, "merge");
    assert_eq!(merge.len(), 1);
    let m = merge[0];
    assert_eq!(
        (&m.geometry, m.cull, m.ds, m.depth.compare, m.depth.write),
        (
            &Geometry::Mesh(6),
            Cull::Front,
            OUTPUT,
            CompareOp::Less,
            true
        )
    );
    assert_eq!(
        m.fragment,
        Fragment::MergeBehind {
            tex: SURF,
            eps: CLIP_EPS
        }
    );
    // Every exit moves `z` in the depth-stencil image too (the tie-free
    // parity draws test it there).
    let exits: Vec<&Draw> = pass_draws(&built.steps, "subtract")
        .into_iter()
        .filter(|d| d.cull == Cull::Front)
        .collect();
    assert_eq!(exits.len(), 2);
    assert!(exits.iter().all(|d| d.depth.write
        && d.depth.compare == CompareOp::Greater
        && d.stencil.unwrap().front.depth_fail == StencilOp::Zero
        && d.fragment == Fragment::WriteDepth { out: SURF }));
    // Their parity draws may drop the back faces where tie-free.
    let parity: Vec<&Draw> = pass_draws(&built.steps, "subtract")
        .into_iter()
        .filter(|d| d.cull == Cull::None)
        .collect();
    assert_eq!(parity.len(), 2);
    assert!(parity.iter().all(|d| d.fragment
        == Fragment::ParityBeforeExit {
            tex: SURF,
            eps: CLIP_EPS
        }));
    // The second product's merge is a draw of its back faces: no quad.
    let c = count(&built.steps, &prep);
    assert_eq!((c.fullscreen_passes, c.footprint_passes), (0, 1));
}

/// The first product's clip draws of [`two_products`] with these triangle
/// counts for box 0 and its cutters 4 and 5, and its exits.
fn first_clip(tris: [usize; 3]) -> (Vec<Draw>, Vec<Draw>) {
    let mut prep = two_products();
    for (m, t) in [0, 4, 5].into_iter().zip(tris) {
        prep.mesh_triangles[m] = t;
    }
    let built = plan(&prep, &ProductOptions::default()).unwrap();
    let exits = pass_draws(&built.steps, "subtract")
        .into_iter()
        .filter(|d| d.cull == Cull::Front)
        .cloned()
        .collect();
    let clip = pass_draws(&built.steps, "clip").into_iter().cloned();
    (clip.collect(), exits)
}

#[test]
fn a_fine_positive_is_swept_over_its_cutters_back_faces() {
    // Box 0 a fine sphere (4000 triangles), its cutters 96 each: the sweep
    // covers where an exit ran, the cutters' back faces cut as the exits.
    let (clip, exits) = first_clip([4000, 96, 96]);
    assert_eq!(clip.len(), 3, "one count draw and one sweep per cutter");
    assert_eq!(clip[0].geometry, Geometry::Mesh(0));
    for (sweep, exit) in clip[1..].iter().zip(&exits) {
        let Geometry::Mesh(y) = exit.geometry else {
            panic!("an exit draws its cutter")
        };
        assert_eq!(
            sweep.geometry,
            Geometry::Footprint {
                mesh: y,
                depth: goldfeather::FAR
            }
        );
        // The exit cut to its cutter's openings where the executor knows
        // them, and the sweep as the exit: `z` moved only where it drew.
        assert!(
            matches!(exit.scissor, Scissor::Openings { of, .. } if of == y),
            "an exit cut to its openings: {exit:?}"
        );
        assert_eq!((sweep.cull, &sweep.scissor), (exit.cull, &exit.scissor));
        assert_eq!((sweep.ds, &sweep.fragment), (OUTPUT, &Fragment::None));
        // Covered twice where the cutters overlap on screen: the second
        // fragment sees the count the first left, kept or cleared.
        let st = sweep.stencil.unwrap();
        assert_eq!(
            (st.front.fail, st.front.pass),
            (StencilOp::Keep, StencilOp::Zero)
        );
    }
}

#[test]
fn a_sweep_over_the_cutters_pays_for_its_draws() {
    // Fewer triangles (2 × 96 against 528) but one draw more: box 0's front
    // faces, one draw (as for boxes of 12 triangles each).
    for tris in [[528, 96, 96], [12, 12, 12]] {
        let (clip, _) = first_clip(tris);
        assert_eq!(clip.len(), 2, "{tris:?}");
        assert!(matches!(
            clip[1].geometry,
            Geometry::Footprint { mesh: 0, .. }
        ));
    }
}

#[test]
fn a_cutter_starting_inside_keeps_the_parity_clip() {
    // The image and the texture differ where no front face is drawn, and
    // the eye correction needs the parity: the product is drawn in the
    // surface image, clipped by parity and merged full-screen.
    let mut near = row_of_boxes();
    near.near_cut = vec![false; 8];
    near.near_cut[4] = true;
    let built = plan(&near, &ProductOptions::default()).unwrap();
    assert_eq!(pass_draws(&built.steps, "clip")[0].cull, Cull::None);
    // Its parity keeps both halves (the ray may start inside it).
    let cutter4 = pass_draws(&built.steps, "subtract")
        .into_iter()
        .find(|d| d.cull == Cull::None && d.geometry == Geometry::Mesh(4))
        .expect("cutter 4's parity draw");
    assert_eq!(
        cutter4.fragment,
        Fragment::NearerThan {
            tex: SURF,
            eps: CLIP_EPS
        }
    );
    assert!(pass_draws(&built.steps, "scs-front")
        .iter()
        .all(|d| d.ds == SURFACE));
    let merge = pass_draws(&built.steps, "merge");
    assert!(matches!(
        merge[..],
        [Draw {
            geometry: Geometry::FullScreen { .. },
            ..
        }]
    ));
}

#[test]
fn an_intersection_is_drawn_within_the_overlap_of_its_rectangles() {
    use crate::scene::fixtures::ExprBuilder;
    // (0 ∩ 1) − 2: every draw and the sweep are cut to the rectangles of
    // both 0 and 1; the clip counts the back faces of 0 and 1.
    let mut prep = row_of_boxes();
    let mut e = ExprBuilder::default();
    let (a, b, c) = (e.leaf(0), e.leaf(1), e.leaf(2));
    let ab = e.inter(a, b);
    let root = e.diff(ab, c);
    prep = Prepared::from_parts(e.build(root), vec![12; 8], prep.mesh_bounds.clone());
    prep.mesh_convex = vec![true; 8];
    let built = plan(&prep, &ProductOptions::default()).unwrap();
    let product: Vec<&Draw> = built
        .steps
        .iter()
        .take_while(|s| !matches!(s, Step::Pass(p) if p == "shade"))
        .filter_map(|s| match s {
            Step::Draw(d) => Some(d),
            _ => None,
        })
        .collect();
    // Fronts, parity and exit, clip, sweep (no merge: drawn in the output).
    assert_eq!(product.len(), 2 + 2 + 2 + 1);
    for d in product {
        let (of, and) = match &d.scissor {
            Scissor::Overlap { of, and } => (of.clone(), and),
            // The subtractions, cut to their openings where known.
            Scissor::Openings { of, and } => (vec![*of], and),
            _ => panic!("not cut to the overlap: {d:?}"),
        };
        assert!(of.len() == 1 && and.contains(&1), "{d:?}");
        assert!(of.contains(&0) || and.contains(&0), "{d:?}");
    }
    let clip = pass_draws(&built.steps, "clip");
    assert_eq!(clip.len(), 3);
    assert!(clip[..2].iter().all(|d| d.cull == Cull::Front));
    let sweep = clip[2].stencil.unwrap();
    assert_eq!((sweep.reference, sweep.compare_mask), (2, 3));
}

#[test]
fn block_minus_disjoint_spheres_subtracts_each_once() {
    let prep = Prepared::new(&block_minus_spheres(16)).unwrap();
    let built = plan(&prep, &ProductOptions::default()).unwrap();
    assert!(!built.steps.iter().any(|s| matches!(s, Step::Loop(_))));
    // One product, drawn in the output: no surface image.
    assert_eq!(built.depth_stencils, 1);
    let c = count(&built.steps, &prep);
    let g = goldfeather::plan(&prep, &ProductOptions::default()).unwrap();
    let gc = count(&g.steps, &prep);
    // 1 front, 16 parity + 16 exits, 1 clip of the block's back faces
    // and its sweep over the block's front faces; then 17 shading draws.
    assert_eq!(c.mesh_draws, 1 + 32 + 1 + 1 + 17);
    // Two subtraction batches of 8 bits and the clip's one sweep over
    // the block's footprint (no merge: the product is drawn in the output).
    assert_eq!((c.fullscreen_passes, c.footprint_passes), (0, 1));
    assert!(c.draws * 5 < gc.draws, "scs {c:?} goldfeather {gc:?}");
}

#[test]
fn the_shade_is_cut_to_one_positive_of_each_product() {
    // ((A ∩ C) − Y) ∪ B: the solid lies in C (smaller on screen than A) or
    // in B, so every mesh's shade is cut to the rectangles of C and B, the
    // cutter's too (it shows only inside the product it cuts).
    use crate::plan::screen::ScreenBox;
    use crate::scene::fixtures::ExprBuilder;
    use crate::scene::Aabb;
    use glam::{DVec2, DVec3};
    let cube = |lo: f64, hi: f64| Aabb {
        min: DVec3::splat(lo),
        max: DVec3::splat(hi),
    };
    let (a, c, y, b) = (0, 1, 2, 3);
    let mut e = ExprBuilder::default();
    let (la, lc, ly, lb) = (e.leaf(a), e.leaf(c), e.leaf(y), e.leaf(b));
    let ac = e.inter(la, lc);
    let cut = e.diff(ac, ly);
    let root = e.union(cut, lb);
    let bounds = vec![
        cube(0.0, 4.0),
        cube(1.0, 3.0),
        cube(2.0, 9.0),
        cube(20.0, 21.0),
    ];
    let mut prep = Prepared::from_parts(e.build(root), vec![12; 4], bounds);
    prep.mesh_convex = vec![true; 4];
    let sb = |lo: f64, hi: f64| {
        Some(ScreenBox {
            lo: DVec2::splat(lo),
            hi: DVec2::splat(hi),
        })
    };
    prep.screen = vec![
        sb(0.0, 40.0),
        sb(10.0, 30.0),
        sb(20.0, 90.0),
        sb(200.0, 210.0),
    ];
    let steps = plan(&prep, &ProductOptions::default()).unwrap().steps;
    let shade: Vec<&Draw> = steps
        .iter()
        .filter_map(|s| match s {
            Step::Draw(d) if matches!(d.fragment, Fragment::ShadeNearDepth { .. }) => Some(d),
            _ => None,
        })
        .collect();
    assert_eq!(shade.len(), 4);
    for d in shade {
        assert_eq!(
            d.scissor,
            Scissor::Within {
                meshes: d.geometry.meshes().to_vec(),
                within: vec![c, b],
            }
        );
    }
}

#[test]
fn cutters_far_apart_on_screen_are_clipped_in_clusters() {
    // Box 0 minus 4 and 5 (two_products), with screen boxes given: cutters
    // at opposite corners of box 0 get a clip draw and a sweep each, where
    // the rectangle of both would cover most of box 0; cutters side by side
    // (their union barely larger than the two) share one.
    use crate::plan::screen::ScreenBox;
    use glam::DVec2;
    let sb = |x0: f64, y0: f64, x1: f64, y1: f64| {
        Some(ScreenBox {
            lo: DVec2::new(x0, y0),
            hi: DVec2::new(x1, y1),
        })
    };
    let clip_scissors = |y4, y5| {
        let mut prep = two_products();
        prep.screen = vec![None; 8];
        prep.screen[0] = sb(0.0, 0.0, 600.0, 600.0);
        prep.screen[4] = y4;
        prep.screen[5] = y5;
        let built = plan(&prep, &ProductOptions::default()).unwrap();
        let clip = pass_draws(&built.steps, "clip");
        let (count, sweep): (Vec<&Draw>, Vec<&Draw>) = clip
            .into_iter()
            .take_while(|d| {
                matches!(
                    d.geometry,
                    Geometry::Mesh(0) | Geometry::Footprint { mesh: 0, .. }
                )
            })
            .partition(|d| matches!(d.geometry, Geometry::Mesh(_)));
        let scissors = |ds: Vec<&Draw>| {
            ds.into_iter()
                .map(|d| d.scissor.clone())
                .collect::<Vec<_>>()
        };
        (scissors(count), scissors(sweep))
    };
    let within = |ys: Vec<u32>| Scissor::Within {
        meshes: vec![0],
        within: ys,
    };
    // A cluster of one cutter is cut as its exits are (its openings, where
    // the executor knows them).
    let opening = |y: u32| Scissor::Openings {
        of: y,
        and: vec![0],
    };
    let apart = clip_scissors(sb(0.0, 0.0, 100.0, 100.0), sb(500.0, 500.0, 600.0, 600.0));
    let each = vec![opening(4), opening(5)];
    assert_eq!(apart, (each.clone(), each.clone()));
    let mut prep = two_products();
    prep.screen = vec![None; 8];
    prep.screen[0] = sb(0.0, 0.0, 600.0, 600.0);
    prep.screen[4] = sb(0.0, 0.0, 100.0, 100.0);
    prep.screen[5] = sb(500.0, 500.0, 600.0, 600.0);
    let built = plan(&prep, &ProductOptions::default()).unwrap();
    let exits: Vec<Scissor> = pass_draws(&built.steps, "subtract")
        .into_iter()
        .filter(|d| matches!(d.geometry, Geometry::Mesh(4 | 5)))
        .map(|d| d.scissor.clone())
        .collect();
    assert!(exits.iter().all(|s| each.contains(s)), "{exits:?}");
    // Those may overlap on the device: the count is set, not incremented, so
    // a pixel two clip draws cover counts once.
    let st = pass_draws(&built.steps, "clip")[0].stencil.unwrap();
    assert_eq!(
        (st.front.pass, st.write_mask, st.reference),
        (StencilOp::Replace, 1, 1)
    );
    let side_by_side = clip_scissors(sb(0.0, 0.0, 100.0, 100.0), sb(100.0, 0.0, 200.0, 100.0));
    let one = vec![within(vec![4, 5])];
    assert_eq!(side_by_side, (one.clone(), one));
}

#[test]
fn cutters_with_a_plane_between_them_and_a_positive_are_dropped() {
    use crate::scene::fixtures::{box_mesh, camera, prim, scene, sphere_mesh, ExprBuilder};
    use glam::DVec3;
    // (T − S − H): tooth T in the corner of sphere S's box, outside the
    // sphere (|corner| > radius); H overlaps T. S subtracts nothing.
    let t = box_mesh(DVec3::new(0.8, 0.8, -0.1), DVec3::new(1.0, 1.0, 0.1));
    let s = sphere_mesh(DVec3::ZERO, 1.0, 24, 12);
    let h = box_mesh(DVec3::new(0.9, 0.9, -0.5), DVec3::new(1.2, 1.2, 0.5));
    let mut e = ExprBuilder::default();
    let (lt, ls, lh) = (e.leaf(0), e.leaf(1), e.leaf(2));
    let d = e.diff(lt, ls);
    let root = e.diff(d, lh);
    let cam = camera(DVec3::new(0.5, 1.0, 6.0), DVec3::ZERO, 35.0, 1.0, 20.0);
    let sc = scene(
        cam,
        vec![
            prim("T", t, [200, 0, 0]),
            prim("S", s, [0, 200, 0]),
            prim("H", h, [0, 0, 200]),
        ],
        e.build(root),
    );
    let prep = Prepared::new(&sc).unwrap();
    // The boxes meet, so the products keep S.
    let prods = goldfeather::products(&prep, goldfeather::DEFAULT_PRODUCT_LIMIT).unwrap();
    assert_eq!(prods.len(), 1);
    assert_eq!(prods[0].len(), 3);
    let tests = Cell::new(100);
    let kept = without_apart_cutters(prods.clone(), &prep, &tests);
    let prims: Vec<(u32, bool)> = kept[0].iter().map(|l| (l.prim, l.negated)).collect();
    assert_eq!(prims, vec![(0, false), (2, true)]);
    assert_eq!(tests.get(), 98, "one pair test per cutter and positive");
    // No tests left: every cutter kept.
    let none = without_apart_cutters(prods.clone(), &prep, &Cell::new(0));
    assert_eq!(none, prods);
    // The plan draws no parity of S.
    let built = plan(&prep, &ProductOptions::default()).unwrap();
    let parity_of = |m: u32| {
        built.steps.iter().any(|s| {
            matches!(s, Step::Draw(d) if d.geometry == Geometry::Mesh(m)
                && matches!(d.fragment, Fragment::ParityBeforeExit { .. } | Fragment::NearerThan { .. }))
        })
    };
    assert!(!parity_of(1) && parity_of(2));
}
