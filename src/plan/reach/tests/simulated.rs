//! The reach pass against a pixel simulation: random frames run with cut
//! clears and copies read and leave what they read and leave with whole ones.

use super::*;

/// Pixel images of a simulated frame: a value per pixel and image.
type Pixels = BTreeMap<Resource, Vec<u64>>;

fn value_of(c: &Clear) -> u64 {
    match *c {
        Clear::DepthStencil { ds, depth, stencil } => {
            1 << 40 | (ds as u64) << 32 | (depth.to_bits() as u64) ^ stencil as u64
        }
        Clear::Texture { tex, depth } => 2 << 40 | (tex as u64) << 32 | depth.to_bits() as u64,
        Clear::Color => 3 << 40,
    }
}

fn each(rect: Rect, mut f: impl FnMut(usize)) {
    for y in rect.y0..rect.y1 {
        for x in rect.x0..rect.x1 {
            f((y * W + x) as usize);
        }
    }
}

/// Runs `steps` on `px` with the clears and copies reaching `reach` (or
/// whole images): every value a draw reads (its images within its grown
/// scissor) goes to `reads`; a draw writes a value of its own (`tag`,
/// step) to the images it may write within its scissor.
fn simulate(
    steps: &[Step],
    reach: Option<&FrameReach>,
    px: &mut Pixels,
    tag: u64,
    reads: &mut Vec<u64>,
) {
    let full = Rect::full(W, H);
    let mut clears = reach.map(|r| r.clears.iter());
    let mut copies = reach.map(|r| r.copies.iter());
    let mut texture_writes = reach.map(|r| r.texture_writes.iter());
    let get = |px: &mut Pixels, r| {
        px.entry(r)
            .or_insert(vec![u64::MAX; (W * H) as usize])
            .clone()
    };
    for (i, s) in steps.iter().enumerate() {
        match s {
            Step::Clear(c) => {
                for r in cleared(c, false) {
                    let need = clears.as_mut().map_or(ClearNeed::Reach(full), |n| {
                        *n.next().expect("a need per cleared image")
                    });
                    let mut img = get(px, r);
                    if let ClearNeed::Reach(rect) = need {
                        each(rect, |p| img[p] = value_of(c));
                    }
                    px.insert(r, img);
                }
            }
            Step::CopyTexture { .. }
            | Step::CopyDepthToTexture { .. }
            | Step::CopyDepthBound { .. } => {
                let rect = copies
                    .as_mut()
                    .map_or(full, |c| *c.next().expect("a region per copy"));
                let (src, dst) = match *s {
                    Step::CopyTexture { src, dst } => {
                        (Resource::Texture(src), Resource::Texture(dst))
                    }
                    Step::CopyDepthToTexture { ds, dst } => {
                        (Resource::DepthStencil(ds), Resource::Texture(dst))
                    }
                    Step::CopyDepthBound { src, dst } => {
                        (Resource::DepthStencil(src), Resource::DepthStencil(dst))
                    }
                    _ => unreachable!("a copy"),
                };
                let from = get(px, src);
                let mut to = get(px, dst);
                each(rect, |p| to[p] = from[p]);
                px.insert(dst, to);
            }
            Step::Draw(d) => {
                // The texture a draw only writes: not read by it, and
                // left alone where nobody reads it after (`dead`).
                let written = written_texture(d).map(Resource::Texture);
                let dead = written.is_some()
                    && texture_writes
                        .as_mut()
                        .is_some_and(|w| !*w.next().expect("a flag per texture write"));
                let Some(rect) = draw_rect(s, &scissor) else {
                    continue;
                };
                for (r, _) in uses(s, false) {
                    if Some(r) == written {
                        continue;
                    }
                    let img = get(px, r);
                    each(rect.grown(READ_MARGIN, READ_MARGIN, W, H), |p| {
                        reads.push(img[p])
                    });
                }
                for (r, _) in uses(s, false) {
                    if dead && Some(r) == written {
                        continue;
                    }
                    if may_write(s, r, false) {
                        let mut img = get(px, r);
                        each(rect, |p| img[p] = tag << 20 | i as u64);
                        px.insert(r, img);
                    }
                }
            }
            Step::Pass(_) | Step::Loop(_) => {}
        }
    }
}

/// A random frame from a small vocabulary of steps on 2 depth-stencils
/// and 3 textures, every image cleared at its start as plans do (a plan
/// reads no image it has not cleared or written).
fn random_frame(seed: u64) -> Vec<Step> {
    let mut x = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut next = |n: u64| {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 33) % n
    };
    let mut steps = vec![clear_ds(0), Step::Clear(Clear::Color), clear_ds(1)];
    steps.extend((0..3).map(clear_tex));
    for _ in 0..12 {
        let (t, u, m) = (next(3) as u8, next(3) as u8, next(7) as u32);
        let ds = next(2) as u8;
        steps.push(match next(10) {
            0 => clear_ds(ds),
            1 => Step::Clear(Clear::Texture {
                tex: t,
                depth: next(2) as f32,
            }),
            2 => Step::CopyTexture { src: t, dst: u },
            3 => Step::CopyDepthToTexture { ds, dst: t },
            4 => draw(Fragment::Shade, ds, m),
            5 => draw(
                Fragment::Peel {
                    prev: t,
                    out: u,
                    shade: next(2) == 0,
                },
                ds,
                m,
            ),
            6 => draw(Fragment::DepthFromTexture { src: t }, ds, m),
            7 => draw(Fragment::WriteDepth { out: t }, ds, m),
            // Never into the output (`plan::validate`).
            8 => Step::CopyDepthBound { src: 0, dst: 1 },
            _ => draw(Fragment::None, ds, m),
        });
    }
    steps
}

/// Random frames, run several times in a row as the executor runs them:
/// with clears and copies cut to `frame_reach` (outputs carried over from
/// frame to frame) every draw reads the values it reads with whole clears
/// and copies, and the outputs end the same, pixel for pixel.
#[test]
fn cut_clears_and_copies_read_and_leave_what_whole_ones_do() {
    let outputs = [Resource::Color, Resource::Prim, Resource::DepthStencil(0)];
    let mut writes = [0; 2];
    for seed in 0..300 {
        let steps = random_frame(seed);
        let (mut whole, mut cut) = (Pixels::new(), Pixels::new());
        let mut kept = KeptImages::new();
        for frame in 0..3 {
            let r = reach_of(&steps, &outputs, &kept);
            for &w in &r.texture_writes {
                writes[w as usize] += 1;
            }
            let (mut a, mut b) = (Vec::new(), Vec::new());
            simulate(&steps, None, &mut whole, frame, &mut a);
            simulate(&steps, Some(&r), &mut cut, frame, &mut b);
            assert!(
                a == b,
                "seed {seed} frame {frame}: a draw read another value\n{steps:#?}"
            );
            for o in &outputs {
                assert!(
                    whole[o] == cut[o],
                    "seed {seed} frame {frame}: output {o:?} differs\n{steps:#?}"
                );
            }
            kept = r.kept;
        }
        // From the second frame on, the outputs' clears are cut.
        assert!(kept.contains_key(&Resource::Color), "seed {seed}");
    }
    // Both dead and read texture writes were exercised.
    assert!(writes[0] > 0 && writes[1] > 0, "{writes:?}");
}
