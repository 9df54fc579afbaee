//! Frames of several plans in one command buffer and one submission:
//! a layered, transparent or Kirsch frame is a sequence of plans (one per
//! peeled layer, each followed by its coverage count), accumulate passes
//! (Hable & Rossignac §6, blended on the GPU) and copies of layers into a
//! host-visible buffer ("keeps": the layers the CPU merges or writes out). The caller
//! knows every plan's loop counts from an earlier frame (the layered driver,
//! `render::sequence`, learns them by running the frame plan by plan); the whole
//! sequence is recorded unrolled, submitted once, and checked on the GPU's
//! occlusion counts afterwards as a single frame is (`layers_fit` per plan):
//! `None` when a count no longer fits, and the caller runs the frame plan by
//! plan again. The recording is kept and replayed while the sequence, the
//! camera's scissors and the device objects stay the same (`record_ms` 0).

use std::ops::Range;
use std::time::Instant;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::record::Group;
use super::targets::ALPHA_TABLE_SIDE;
use super::{
    add_gpu_times, layers_fit, unroll, whole_image_region, Clock, ExecStats, Executor, FrameStart,
};
use super::{gpu_scene, Recorded, Scissors};
use crate::images::Images;
use crate::plan::reach;
use crate::plan::tie_free::TieFree;
use crate::plan::usage::Resource;
use crate::plan::{Plan, Step};
use crate::vk::error::VkError;
use crate::vk::memory::Buffer;
use crate::vk::readback::{decode, decode_normals, Raw};
use crate::vk::scissor::Rect;
use crate::vk::submit;
use crate::vk::sync::{self, REST};

/// A layer's view-space unit normals, row-major (zero where nothing was drawn;
/// `readback::decode_normals`).
type Normals = Vec<[f32; 3]>;

/// One item of a sequence frame.
#[derive(Clone, Debug, PartialEq)]
pub enum SeqItem {
    /// A plan, its loops unrolled to `loops` (one count per top-level loop).
    Plan {
        /// The plan.
        plan: Plan,
        /// Iterations of each of its top-level loops.
        loops: Vec<u32>,
    },
    /// Blends the last plan's layer into the accumulation target
    /// ([`Executor::accumulate`]); `first` starts it from zero with the
    /// sequence's opacity table.
    Accumulate {
        /// Start the accumulation from zero.
        first: bool,
    },
    /// Copies the last plan's images (colour, id, output depth; normals when
    /// on) into the next slot of the keep buffer ([`Executor::read_kept`]).
    Keep,
}

/// What the GPU counted in one plan of a sequence.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlanCounts {
    /// Samples of all its counted draws.
    pub samples: u64,
    /// Samples of its counted draws after its last loop (Kirsch's layer count).
    pub final_samples: u64,
}

/// A sequence frame's statistics and each plan's counts, in item order.
#[derive(Clone, Debug, PartialEq)]
pub struct SeqFrame {
    /// The whole sequence's statistics.
    pub stats: ExecStats,
    /// What the GPU counted in each plan, in item order.
    pub plans: Vec<PlanCounts>,
}

/// The executor's sequence objects: the command buffer kept for replays, the
/// keep buffer and the opacity table's staging buffer (read by every replay).
#[derive(Default)]
pub(super) struct SeqState {
    cmd: Option<vk::CommandBuffer>,
    kept: Option<SeqRecording>,
    keep: Option<Buffer>,
    /// Bytes of one slot of `keep`.
    slot_bytes: u64,
    alpha: Option<(Vec<f32>, Buffer)>,
}

/// What a kept sequence recording was made for.
#[derive(PartialEq)]
struct SeqKey {
    items: Vec<SeqItem>,
    rects: Vec<Rect>,
    epoch: u64,
    ties: TieFree,
    /// Normals, transparency, pass timestamps and the push-constant flags,
    /// the emulated vertex snapping: every setting the recording depends on
    /// (the profile's clears and frame timestamps stay with the executor).
    settings: (bool, bool, bool, u32, [u32; 2]),
    keep: Option<vk::Buffer>,
    alpha: Option<vk::Buffer>,
}

struct SeqRecording {
    key: SeqKey,
    stats: ExecStats,
    queries: Vec<Group>,
    marks: Vec<String>,
    /// Each plan's occlusion queries.
    ranges: Vec<Range<usize>>,
}

/// Raw handles of the images a keep copies.
struct KeepSources {
    color: vk::Image,
    prim: vk::Image,
    ds: Vec<vk::Image>,
    normal: Option<vk::Image>,
}

impl Executor {
    /// Runs `items` as one frame in one submission (see the module docs):
    /// `alpha` is the opacity table of a first [`SeqItem::Accumulate`] (as
    /// [`Executor::accumulate`] takes it). `None` when the GPU's counts show
    /// that some plan's loop counts no longer fit: the images are then
    /// unspecified and the caller runs the frame plan by plan.
    pub fn execute_sequence(
        &mut self,
        items: &[SeqItem],
        alpha: Option<&[f32]>,
    ) -> Result<Option<SeqFrame>, VkError> {
        let _layer = self.shared.layer_use();
        // A sequence writes the outputs without tracking what they hold
        // (`plan::reach`): the next single frame clears them whole.
        self.kept.clear();
        let plans: Vec<(&Plan, &[u32])> = items
            .iter()
            .filter_map(|i| match i {
                SeqItem::Plan { plan, loops } => Some((plan, loops.as_slice())),
                _ => None,
            })
            .collect();
        let (Some(&(first, _)), Some(&(last, _))) = (plans.first(), plans.last()) else {
            return Err(VkError::Plan("a sequence frame needs a plan".into()));
        };
        if !matches!(items[0], SeqItem::Plan { .. }) {
            return Err(VkError::Plan("a sequence frame starts with a plan".into()));
        }
        for &(p, loops) in &plans {
            if loops.len() != p.loops().count() {
                return Err(VkError::Plan(format!(
                    "{} loop counts for a plan of {} loops",
                    loops.len(),
                    p.loops().count()
                )));
            }
        }
        let accumulates = items
            .iter()
            .any(|i| matches!(i, SeqItem::Accumulate { .. }));
        if accumulates && !self.transparency {
            return Err(VkError::Plan(
                "accumulate in a sequence needs set_transparency(true)".into(),
            ));
        }
        let start = Instant::now();
        // All plans as one, for what depends on a frame's steps as a whole: the
        // check, the images' count and the tie-free decisions (which depend
        // only on the algorithm and the tolerances drawn).
        let whole = Plan {
            algo: first.algo.clone(),
            depth_stencils: plans.iter().map(|p| p.0.depth_stencils).max().unwrap_or(1),
            textures: plans.iter().map(|p| p.0.textures).max().unwrap_or(0),
            stencil_bits: plans.iter().map(|p| p.0.stencil_bits).max().unwrap_or(0),
            output_ds: last.output_ds,
            steps: plans.iter().flat_map(|p| p.0.steps.clone()).collect(),
        };
        self.prepare_plan(&whole)?;
        let scene = self.scene.as_ref().expect("checked above");
        let cam = scene.cam;
        let openings = self.opening_rects.get(&self.cut_away, scene, &self.desc);
        let exact = Scissors::exact(scene, &self.desc, openings);
        self.camera.write(&cam)?;
        self.last_cam = Some(cam);
        // Before the key: growing a query pool replaces it (a new epoch).
        let all: Vec<(&Step, Group)> = plans.iter().flat_map(|p| unroll(p.0, p.1)).collect();
        self.ensure_queries(&all)?;
        let keeps = items.iter().filter(|i| matches!(i, SeqItem::Keep)).count() as u64;
        self.ensure_keep(keeps)?;
        let first_table = items
            .iter()
            .any(|i| matches!(i, SeqItem::Accumulate { first: true }));
        if first_table {
            let table =
                alpha.ok_or_else(|| VkError::Plan("a first accumulate needs a table".into()))?;
            self.ensure_alpha(table)?;
        }
        let key = SeqKey {
            items: items.to_vec(),
            rects: exact.rects.clone(),
            epoch: self.epoch,
            ties: self.ties.clone(),
            settings: (
                self.normals,
                self.transparency,
                self.pass_timestamps,
                self.flags(),
                self.profile
                    .vertex_snapping_emulation
                    .map(|r| r.ndc_step(self.desc.width, self.desc.height))
                    .unwrap_or_default()
                    .map(f32::to_bits),
            ),
            keep: self.seq.keep.as_ref().map(|b| b.raw),
            alpha: first_table
                .then(|| self.seq.alpha.as_ref().map(|a| a.1.raw))
                .flatten(),
        };
        let mut f = FrameStart {
            start,
            clock: Clock::default(),
            known: None,
            exact,
            still: true,
            pipelines_before: (self.pipelines.created, self.pipelines.create_ms),
        };
        let kind = if self.seq.kept.as_ref().is_some_and(|k| k.key == key) {
            Recorded::Replayed
        } else {
            self.seq.kept = None;
            self.rects = f.exact.clone();
            let t = crate::vk::cpu_clock::CpuInstant::now();
            let rec = self.record_sequence(items, key)?;
            f.clock.record_ms += t.elapsed_ms();
            self.seq.kept = Some(rec);
            Recorded::New
        };
        let cmd = self.seq.cmd.expect("recorded above");
        f.clock.submitting();
        self.submit.submit(cmd, &[], &[])?;
        self.submit.wait()?;
        let rec = self.seq.kept.as_ref().expect("recorded above");
        let samples =
            submit::query_results(&self.shared.device, self.occlusion.pool, rec.queries.len())?;
        let mut counts = Vec::with_capacity(plans.len());
        for (&(plan, loops), r) in plans.iter().zip(&rec.ranges) {
            let (groups, s) = (&rec.queries[r.clone()], &samples[r.clone()]);
            if !layers_fit(plan, loops, groups, s) {
                return Ok(None);
            }
            let after = groups
                .iter()
                .rposition(Option::is_some)
                .map_or(0, |i| i + 1);
            counts.push(PlanCounts {
                samples: s.iter().sum(),
                final_samples: s[after..].iter().sum(),
            });
        }
        let mut stats = rec.stats.clone();
        stats.recorded = kind;
        stats.counts.submits = 1;
        stats.counts.loop_iterations = plans.iter().flat_map(|p| p.1.to_vec()).collect();
        stats.counts.samples_counted = counts.iter().map(|c| c.samples).sum();
        stats.counts.final_samples = counts.last().map_or(0, |c| c.final_samples);
        add_gpu_times(&mut stats, &self.shared, self.timestamps.pool, &rec.marks)?;
        let stats = self.end_frame(last, f, Some(stats))?;
        Ok(Some(SeqFrame {
            stats,
            plans: counts,
        }))
    }

    /// Records `items` into the sequence command buffer (allocated on first
    /// use), every image starting and ending in `REST`.
    fn record_sequence(&mut self, items: &[SeqItem], key: SeqKey) -> Result<SeqRecording, VkError> {
        let cmd = match self.seq.cmd {
            Some(c) => c,
            None => *self.seq.cmd.insert(self.submit.allocate()?),
        };
        let flat: Vec<Vec<(&Step, Group)>> = items
            .iter()
            .filter_map(|i| match i {
                SeqItem::Plan { plan, loops } => Some(unroll(plan, loops)),
                _ => None,
            })
            .collect();
        let (occ_cap, ts_cap) = (self.occlusion.cap, self.timestamps.cap);
        let shared = self.shared.clone();
        let keep = self.seq.keep.as_ref().map(|b| b.raw);
        let slot_bytes = self.seq.slot_bytes;
        let t = self.targets.as_ref().expect("targets made above");
        let sources = KeepSources {
            color: t.color.raw,
            prim: t.prim.raw,
            ds: t.ds.iter().map(|d| d.raw).collect(),
            normal: t.normal.as_ref().map(|n| n.raw),
        };
        let (w, h) = (self.desc.width, self.desc.height);
        let reach = self.sequence_reach(items, &flat);
        // Out of `self` while the recorder borrows it; put back below.
        let alpha = self.seq.alpha.take();
        self.submit.begin(cmd, false)?;
        let mut rec = self.recorder();
        rec.use_reach(&reach, 0);
        rec.begin(cmd, occ_cap, ts_cap);
        let mut ranges = Vec::new();
        let (mut plan_i, mut slot, mut output) = (0, 0u64, 0u8);
        let mut result = Ok(());
        for item in items {
            result = match item {
                SeqItem::Plan { plan, .. } => {
                    let steps = &flat[plan_i];
                    plan_i += 1;
                    rec.set_outputs(plan.output_ds);
                    rec.plan_blocks(&steps.iter().map(|(s, _)| *s).collect::<Vec<_>>());
                    let q0 = rec.queries.len();
                    let r = steps.iter().try_for_each(|(s, g)| {
                        rec.group = *g;
                        rec.step(s)
                    });
                    rec.group = None;
                    rec.finish_plan();
                    ranges.push(q0..rec.queries.len());
                    output = plan.output_ds;
                    r
                }
                SeqItem::Accumulate { first } => {
                    let table = first.then(|| alpha.as_ref().map(|a| &a.1)).flatten();
                    rec.accumulate_pass(cmd, table)
                }
                SeqItem::Keep => {
                    let buf = keep.expect("the keep buffer was made for the keeps");
                    record_keep(
                        &shared.device,
                        cmd,
                        &sources,
                        output,
                        buf,
                        slot * slot_bytes,
                        [w, h],
                    );
                    slot += 1;
                    Ok(())
                }
            };
            if result.is_err() {
                break;
            }
        }
        rec.end();
        let (stats, queries, marks) = (rec.stats, rec.queries, rec.marks);
        self.seq.alpha = alpha;
        result?;
        if slot > 0 {
            submit::transfer_to_host_barrier(&shared.device, cmd);
        }
        self.submit.end(cmd)?;
        Ok(SeqRecording {
            key,
            stats,
            queries,
            marks,
            ranges,
        })
    }

    /// What the clears and copies of a sequence frame of `items` (its plans
    /// unrolled to `flat`) reach, over all its plans' steps as one frame
    /// (`plan::reach::sequence_reach`): a copy one plan makes reaches what
    /// later plans read of it, and the images an accumulate pass or a keep
    /// copies are read whole there. The outputs' contents are taken as
    /// unknown (a sequence frame does not track them).
    fn sequence_reach(&self, items: &[SeqItem], flat: &[Vec<(&Step, Group)>]) -> reach::FrameReach {
        let normals = self.normals;
        let mut plans = flat.iter();
        let mut output = 0;
        let mut all: Vec<reach::Item<'_>> = Vec::new();
        for item in items {
            match item {
                SeqItem::Plan { plan, .. } => {
                    let steps = plans.next().expect("a step list per plan");
                    all.extend(steps.iter().map(|(s, _)| reach::Item::Step(s)));
                    output = plan.output_ds;
                }
                SeqItem::Accumulate { .. } => {
                    all.extend([Resource::Color, Resource::Prim].map(reach::Item::ReadWhole))
                }
                SeqItem::Keep => all.extend(
                    reach::outputs(output, normals)
                        .into_iter()
                        .map(reach::Item::ReadWhole),
                ),
            }
        }
        let (w, h) = (self.desc.width, self.desc.height);
        let outputs = reach::outputs(output, normals);
        let images = self.reach_images(&outputs);
        let unions = self.rects.unions();
        reach::sequence_reach(&all, |s| unions.scissor(s, w, h), images)
    }

    /// A keep buffer of at least `slots` slots (a larger one replaces it).
    fn ensure_keep(&mut self, slots: u64) -> Result<(), VkError> {
        let px = self.desc.width as u64 * self.desc.height as u64;
        let slot_bytes = px * (12 + if self.normals { 16 } else { 0 });
        let have = self.seq.keep.as_ref().map_or(0, |b| b.size);
        if slots == 0 || (self.seq.slot_bytes == slot_bytes && have >= slots * slot_bytes) {
            return Ok(());
        }
        self.seq.keep = None;
        self.seq.keep = Some(Buffer::new(
            &self.shared,
            "kept layers",
            slots * slot_bytes,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?);
        self.seq.slot_bytes = slot_bytes;
        Ok(())
    }

    /// The opacity table's staging buffer holding `table` (1 beyond its end).
    fn ensure_alpha(&mut self, table: &[f32]) -> Result<(), VkError> {
        if self.seq.alpha.as_ref().is_some_and(|a| a.0 == table) {
            return Ok(());
        }
        self.seq.alpha = Some((table.to_vec(), alpha_staging(&self.shared, table)?));
        Ok(())
    }

    /// Slot `slot` of the last sequence frame's keeps: the layer's images and,
    /// when normals were on, its view-space normals.
    pub fn read_kept(&self, slot: u64) -> Result<(Images, Option<Normals>), VkError> {
        let buf = self
            .seq
            .keep
            .as_ref()
            .ok_or_else(|| VkError::Plan("read_kept without a sequence frame".into()))?;
        let (w, h) = (self.desc.width, self.desc.height);
        let plane = w as usize * h as usize * 4;
        let base = (slot * self.seq.slot_bytes) as usize;
        let bytes = buf.mapped()?;
        if base + self.seq.slot_bytes as usize > bytes.len() {
            return Err(VkError::Plan(format!("no kept slot {slot}")));
        }
        let at = |k: usize| &bytes[base + k * plane..base + (k + 1) * plane];
        let scene = self.scene.as_ref().expect("scene uploaded");
        let images = decode(
            Raw {
                width: w,
                height: h,
                color: at(0),
                prim: at(1),
                depth: at(2),
            },
            self.desc.depth_format,
            &scene.camera,
            gpu_scene::convention(&self.desc),
            scene.background,
        );
        let normals = (self.seq.slot_bytes as usize > 3 * plane).then(|| {
            decode_normals(
                &bytes[base + 3 * plane..base + 7 * plane],
                &scene.camera.view(),
            )
        });
        Ok((images, normals))
    }
}

/// A host-written staging buffer of the opacity table (`ALPHA_TABLE_SIDE`²
/// floats: `table[i]`, 1 beyond its end).
pub(super) fn alpha_staging(
    shared: &std::sync::Arc<crate::vk::instance::Shared>,
    table: &[f32],
) -> Result<Buffer, VkError> {
    let side = ALPHA_TABLE_SIDE as usize;
    assert!(table.len() <= side * side, "one opacity per 16-bit id");
    let mut buf = Buffer::new(
        shared,
        "alpha table",
        (side * side * 4) as u64,
        vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::CpuToGpu,
    )?;
    let bytes = buf.mapped_mut()?;
    for (i, b) in bytes.chunks_exact_mut(4).enumerate() {
        b.copy_from_slice(&table.get(i).copied().unwrap_or(1.0).to_ne_bytes());
    }
    Ok(buf)
}

/// Records copies of the colour, primitive id, depth of `output` and (when
/// on) normals, all resting in `REST`, to `buffer` at `offset`, planes in that
/// order.
fn record_keep(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    src: &KeepSources,
    output: u8,
    buffer: vk::Buffer,
    offset: u64,
    [w, h]: [u32; 2],
) {
    let plane = w as u64 * h as u64 * 4;
    let color = vk::ImageAspectFlags::COLOR;
    let mut copies = vec![
        (src.color, color, 0),
        (src.prim, color, plane),
        (
            src.ds[output as usize],
            vk::ImageAspectFlags::DEPTH,
            2 * plane,
        ),
    ];
    copies.extend(src.normal.map(|n| (n, color, 3 * plane)));
    let layout = sync::access(REST).layout;
    for (img, aspect, at) in copies {
        let region = whole_image_region(aspect, offset + at, w, h);
        // SAFETY: outside rendering; the image allows transfer src and rests in
        // `layout` (after `finish_frame`); the region fits the keep buffer,
        // sized for every slot of the sequence.
        unsafe { device.cmd_copy_image_to_buffer(cmd, img, layout, buffer, &[region]) };
    }
}
