//! Layered frames in one submission. A layered frame (the layers of
//! the solid, its transparency composited on the GPU, Kirsch's layers) is a few
//! streams of layers, each layer some plans whose last counts the pixels it
//! covers, and each stream stops at a layer the caller's rule rejects. How many
//! layers a stream has is known only once they are peeled, and so are the CST
//! plans' own peel loops.
//!
//! The first frame ([`frame`] without a memo) runs layer by layer as
//! before, a submission and a CPU wait per plan, and notes every stream's layer
//! count, the stop that ended it and every plan's loop counts. Later frames
//! record the whole frame with those counts into one command buffer
//! (`vk::Executor::execute_sequence`: plans, accumulate passes, copies of the
//! layers the CPU needs into a host buffer), submit it once, and check the
//! GPU's counts afterwards: every plan's loops as a single frame checks them,
//! and the stop rule on each layer's coverage (every layer but a stream's last
//! goes on, the last stops as it did). A frame that does not pass is run layer
//! by layer again (its images never depend on the memo). The recording is kept,
//! so a second frame of the same scene and camera records nothing.
//!
//! This is the "previous frame's layer count with a GPU check and a fallback"
//! scheme. Conditional rendering (`VK_EXT_conditional_rendering`, which
//! lavapipe has) would skip draws past the last layer, but not the clears,
//! copies and barriers every layer plan records, nor bound the CST peel loops
//! inside each layer plan without unrolling them to their worst case.
#![deny(unsafe_code)]

use super::{GpuRenderer, RenderError};
use crate::output::Images;
use peeltrim::plan::Plan;
use peeltrim::vk::{ExecStats, Recorded, SeqItem};

/// Which count of a layer's last plan is its coverage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Counted {
    /// All its counted draws' samples (a coverage plan).
    Samples,
    /// Its counted draws' samples after its last loop (Kirsch's layer plan).
    Final,
}

/// One layer of a stream: its plans, and what follows them unless the stop
/// rule rejects the layer.
pub struct Layer {
    pub plans: Vec<Plan>,
    pub counted: Counted,
    /// Blend it into the accumulation target (`Some(first)`).
    pub accumulate: Option<bool>,
    /// Copy its images to the CPU.
    pub keep: bool,
}

/// The stop rule's verdict on a layer and its coverage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// Keep it and go on.
    Go,
    /// Drop it (nothing follows its plans) and stop.
    Before,
    /// Keep it and stop.
    After,
}

/// A stream of layers: at most `cap`, layer `k`'s plans by `layer(k)`, and the
/// stop rule on layer `k` covering `pixels`.
pub struct Stream<'a> {
    pub cap: u32,
    pub layer: Box<dyn FnMut(u32) -> Result<Layer, RenderError> + 'a>,
    pub stop: Box<dyn Fn(u32, u64) -> Stop + 'a>,
}

/// A layer the stop rule kept.
pub struct Peeled {
    /// Pixels it covers.
    pub covered: u64,
    /// Its images and (normals on) normals, when its [`Layer::keep`].
    pub images: Option<(Images, Option<Vec<[f32; 3]>>)>,
}

/// A layered frame.
pub struct SeqOut {
    /// Per stream, its kept layers.
    pub streams: Vec<Vec<Peeled>>,
    /// Per stream, the layers peeled (the rejected last one included).
    pub peeled: Vec<u32>,
    /// The frame's figures (submissions of a failed one-submit try included).
    pub stats: ExecStats,
}

/// What the last frame needed: per stream its layers and last verdict, and
/// each plan's loop counts in frame order.
#[derive(Clone, Debug, PartialEq)]
struct Memo {
    layers: Vec<u32>,
    last: Vec<Stop>,
    loops: Vec<Vec<u32>>,
}

/// What a renderer's layered frames needed, by the kind of frame (a frame
/// may run several: the layers, then the highlight's).
#[derive(Default)]
pub struct Sequencer {
    memos: Vec<(&'static str, Memo)>,
}

/// One frame of `streams` on `gpu` (the scene uploaded), `kind` naming what
/// it is among the renderer's frames. `alpha`: the opacity table of the first
/// accumulate; `check_keep(n)` is asked before the `n`-th layer is copied to
/// the CPU (a memory budget).
pub fn frame(
    gpu: &mut GpuRenderer,
    kind: &'static str,
    streams: &mut [Stream<'_>],
    alpha: Option<&[f32]>,
    check_keep: &dyn Fn(u64) -> Result<(), RenderError>,
) -> Result<SeqOut, RenderError> {
    let memos = &mut gpu.layered.memos;
    let memo = memos
        .iter()
        .position(|m| m.0 == kind)
        .map(|i| memos.swap_remove(i).1);
    let mut tried = ExecStats::default();
    if let Some(memo) = memo.filter(|m| m.layers.len() == streams.len()) {
        match one_submit(gpu, streams, alpha, &memo)? {
            Ok(out) => {
                gpu.layered.memos.push((kind, memo));
                return Ok(out);
            }
            Err(stats) => tried = stats,
        }
    }
    let (mut out, memo) = stepwise(gpu, streams, alpha, check_keep)?;
    tried.accumulate(&out.stats);
    out.stats = ExecStats {
        recorded: Recorded::Stepwise,
        ..tried
    };
    gpu.layered.memos.push((kind, memo));
    Ok(out)
}

/// The frame layer by layer, each plan a frame of its own: what it needs.
fn stepwise(
    gpu: &mut GpuRenderer,
    streams: &mut [Stream<'_>],
    alpha: Option<&[f32]>,
    check_keep: &dyn Fn(u64) -> Result<(), RenderError>,
) -> Result<(SeqOut, Memo), RenderError> {
    let mut memo = Memo {
        layers: Vec::new(),
        last: Vec::new(),
        loops: Vec::new(),
    };
    let mut out = SeqOut {
        streams: Vec::new(),
        peeled: Vec::new(),
        stats: ExecStats::default(),
    };
    let mut kept = 0;
    for s in streams.iter_mut() {
        let (mut layers, mut last) = (Vec::new(), Stop::Go);
        let mut k = 0;
        while k < s.cap {
            let layer = (s.layer)(k)?;
            k += 1;
            let mut covered = 0;
            for p in &layer.plans {
                let st = gpu.exec.execute(p)?;
                covered = match layer.counted {
                    Counted::Samples => st.counts.samples_counted,
                    Counted::Final => st.counts.final_samples,
                };
                memo.loops.push(st.counts.loop_iterations.clone());
                out.stats.accumulate(&st);
            }
            last = (s.stop)(k - 1, covered);
            if last == Stop::Before {
                break;
            }
            if let Some(first) = layer.accumulate {
                gpu.exec.accumulate(first.then_some(alpha.unwrap_or(&[])))?;
                out.stats.counts.submits += 1;
            }
            let images = if layer.keep {
                kept += 1;
                check_keep(kept)?;
                Some((gpu.exec.read_back()?, gpu.exec.read_normals()?))
            } else {
                None
            };
            layers.push(Peeled { covered, images });
            if last == Stop::After {
                break;
            }
        }
        memo.layers.push(k);
        memo.last.push(last);
        out.peeled.push(k);
        out.streams.push(layers);
    }
    Ok((out, memo))
}

/// The frame as `memo` says in one submission: `Err` with its figures when
/// the GPU's counts show it no longer fits.
fn one_submit(
    gpu: &mut GpuRenderer,
    streams: &mut [Stream<'_>],
    alpha: Option<&[f32]>,
    memo: &Memo,
) -> Result<Result<SeqOut, ExecStats>, RenderError> {
    let mut items = Vec::new();
    // Per stream, per layer: (index of its counted plan, counted, keep).
    let mut shape: Vec<Vec<(usize, Counted, bool)>> = Vec::new();
    let mut loops = memo.loops.iter();
    let mut plan_i = 0;
    for (s, (&n, &last)) in streams.iter_mut().zip(memo.layers.iter().zip(&memo.last)) {
        let mut layers = Vec::new();
        for k in 0..n {
            let layer = (s.layer)(k)?;
            for p in layer.plans {
                let Some(l) = loops.next().filter(|l| l.len() == p.loops().count()) else {
                    return Ok(Err(ExecStats::default()));
                };
                items.push(SeqItem::Plan {
                    plan: p,
                    loops: l.clone(),
                });
                plan_i += 1;
            }
            layers.push((plan_i - 1, layer.counted, layer.keep));
            if k + 1 == n && last == Stop::Before {
                break;
            }
            items.extend(layer.accumulate.map(|first| SeqItem::Accumulate { first }));
            if layer.keep {
                items.push(SeqItem::Keep);
            }
        }
        shape.push(layers);
    }
    if items.is_empty() || loops.next().is_some() {
        return Ok(Err(ExecStats::default()));
    }
    let Some(frame) = gpu.exec.execute_sequence(&items, alpha)? else {
        return Ok(Err(ExecStats {
            counts: peeltrim::vk::Counts {
                submits: 1,
                ..Default::default()
            },
            ..Default::default()
        }));
    };
    let mut out = SeqOut {
        streams: Vec::new(),
        peeled: memo.layers.clone(),
        stats: frame.stats,
    };
    let mut slot = 0;
    for ((s, layers), &last) in streams.iter().zip(&shape).zip(&memo.last) {
        let mut kept = Vec::new();
        for (k, &(pi, counted, keep)) in layers.iter().enumerate() {
            let c = frame.plans[pi];
            let covered = match counted {
                Counted::Samples => c.samples,
                Counted::Final => c.final_samples,
            };
            let verdict = (s.stop)(k as u32, covered);
            let is_last = k + 1 == layers.len();
            // A stream that ran to its cap ends on `Go`.
            let want = if is_last { last } else { Stop::Go };
            if verdict != want {
                return Ok(Err(out.stats));
            }
            if verdict == Stop::Before {
                break;
            }
            let images = if keep {
                slot += 1;
                Some(gpu.exec.read_kept(slot - 1)?)
            } else {
                None
            };
            kept.push(Peeled { covered, images });
        }
        out.streams.push(kept);
    }
    Ok(Ok(out))
}
