//! Embedding: a plan's frame recorded into a host engine's command buffer,
//! depth-tested into the host's own colour and depth attachments: its final
//! depth-equal shade drawn straight into them (`exec::record::host`), or, where
//! that cannot be ([`HostPath`]), the frame composited into them by one
//! full-screen pass (`vk::composite`). Nothing here submits to a queue (see
//! docs/embedding.md for the full synchronization contract, repeated on
//! [`Embedder::record`]).
//!
//! The frame itself is the executor's unrolled recording (loops unrolled to
//! counts, as in the standalone replay of the performance work): the counts
//! start as given ([`Embedder::set_loop_counts`], e.g. the CPU estimate of
//! `embed::LoopCounts::Estimate`, or learnt by [`Embedder::prepare`]). Each
//! frame's occlusion counts are copied on the GPU (`vkCmdCopyQueryPoolResults`)
//! into a host-visible ring slot per frame in flight (plus one), and checked when
//! that slot comes round again, i.e. after the host has waited for the frame: no
//! CPU wait is ever added. A failed check corrects the counts of later frames:
//! doubled where the last head still found samples (the frame missed layers),
//! shrunk to one past the last head with samples where heads were left empty
//! (the frame was right, only slower).
#![warn(missing_docs)]

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use serde::Serialize;

use super::composite::{check_host_formats, is_srgb, Composite};
use super::error::{Check, VkError};
use super::exec::{
    copy_counts, final_shade, host_barriers, peel_depth, ExecDesc, ExecStats, Executor, HostShade,
    Unrolled,
};
use super::instance::{Context, Shared};
use super::memory::Buffer;
use super::submit;
use super::sync::{self, REST};
use crate::plan::cut_away::CutAway;
use crate::plan::usage::Usage;
use crate::plan::Plan;

/// The host's attachments for one frame. Both are views of 2D images of
/// `extent` with one mip level and one layer, and as many samples per pixel
/// as the embedder's images (`ExecDesc::samples`, `EmbedDesc::samples`): the
/// CSG's final shade tests and writes the host's depth per sample, and the
/// host resolves; see [`Embedder::record`] for the layouts they must be in.
#[derive(Clone, Copy, Debug)]
pub struct HostTargets {
    /// A colour view whose format is a float or UNORM/SRGB colour-attachment
    /// format (peeltrim writes RGBA in 0..1).
    pub color_view: vk::ImageView,
    /// The format of the colour image (peeltrim's pipelines are made for it).
    pub color_format: vk::Format,
    /// A view of the depth aspect of a depth or depth-stencil image (any depth
    /// format the device supports as an attachment); stencil is not touched.
    pub depth_view: vk::ImageView,
    /// The format of the depth image.
    pub depth_format: vk::Format,
    /// Width and height of both images: the embedder's size.
    pub extent: [u32; 2],
}

/// How an embedded frame's final shading reached the host's attachments
/// (`ExecStats::host_path` of [`Embedder::record`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum HostPath {
    /// The plan's final depth-equal shade drawn straight into the host's
    /// attachments under the host's depth test (`vk::exec::record::host`): the
    /// standalone frame's work, no composite. What every GPU algorithm but
    /// `blister-paper` gets without shadows and trimmed surfaces.
    Direct,
    /// The fallback, because shadows are on ([`Embedder::set_shadow`]): the
    /// shadow pass reads peeltrim's own colour, ids, depth and normals, so the
    /// frame is drawn into peeltrim's images, shadowed, and composited into the
    /// host's attachments by one full-screen pass (`vk::composite`).
    CompositeShadows,
    /// The fallback, because the plan does not end in the depth-equal shade
    /// (`blister-paper` takes its colour from the peel; CST with trimmed
    /// surfaces ends in their merge): composited as above.
    CompositePlan,
}

/// One frame in flight: where its occlusion counts land and what they check.
struct Slot {
    counts: Buffer,
    pending: Option<(Plan, Unrolled)>,
}

/// Records plans into a host's command buffers (see the module doc).
pub struct Embedder {
    shared: Arc<Shared>,
    exec: Executor,
    slots: Vec<Slot>,
    frame: u64,
    /// Loop counts to unroll to (learnt standalone, then adjusted by checks).
    layers: Option<(Plan, Vec<u32>)>,
    /// The host formats last checked (`check_host_formats`).
    host_formats: Option<(vk::Format, vk::Format)>,
    composite: Option<Composite>,
    sampler: vk::Sampler,
    /// What `record` draws.
    plan: Option<Plan>,
    /// Where its final shade's pieces may skip the check of the output depth
    /// (`plan::cut_away`; none unless the embedding sets it).
    cut_away: CutAway,
    /// Shadows of a light, darkening each frame before the composite (the
    /// fallback they need, [`HostPath::CompositeShadows`]).
    shadow: Option<super::shadow::EmbeddedShadow>,
}

impl Embedder {
    /// An embedder whose internal images have `desc`'s size and depth set-up;
    /// `frames_in_flight`: the most recorded frames the host has submitted and not
    /// yet waited for at any time (1 for a host that waits every frame).
    pub fn new(ctx: &Context, desc: &ExecDesc, frames_in_flight: u32) -> Result<Embedder, VkError> {
        let _layer = ctx.shared.layer_use();
        let shared = ctx.shared.clone();
        let mut exec = Executor::new(ctx, desc)?;
        // Nobody reads an embedded frame's per-pass GPU times, and lavapipe
        // ends its binned scene at each timestamp: only the frame's two.
        exec.set_pass_timestamps(false);
        let sci = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST);
        // SAFETY: valid create info on a live device.
        let sampler =
            unsafe { shared.device.create_sampler(&sci, None) }.check("vkCreateSampler")?;
        let slots = (0..frames_in_flight.max(1) + 1)
            .map(|i| {
                Ok(Slot {
                    counts: Buffer::new(
                        &shared,
                        &format!("embed counts {i}"),
                        16,
                        vk::BufferUsageFlags::TRANSFER_DST,
                        MemoryLocation::GpuToCpu,
                    )?,
                    pending: None,
                })
            })
            .collect::<Result<Vec<_>, VkError>>()?;
        Ok(Embedder {
            shared,
            exec,
            slots,
            frame: 0,
            layers: None,
            host_formats: None,
            composite: None,
            sampler,
            plan: None,
            cut_away: CutAway::none(),
            shadow: None,
        })
    }

    /// Size and depth set-up of the internal images.
    pub fn desc(&self) -> &ExecDesc {
        self.exec.desc()
    }

    /// The executor (upload meshes, move the camera, run standalone frames).
    pub(crate) fn executor(&mut self) -> &mut Executor {
        &mut self.exec
    }

    /// The images of the last standalone frame, read back to the CPU
    /// ([`Executor::read_back`]).
    pub fn read_back(&mut self) -> Result<crate::images::Images, VkError> {
        self.exec.read_back()
    }

    /// Whether frames also write the normal buffer, which shadows and the
    /// blueprint styles read (Kirsch, Nienhaus & Döllner §5.2).
    pub fn set_normals(&mut self, on: bool) {
        self.exec.set_normals(on);
    }

    /// Shadows recorded after each frame (`None`: none). The executor must write
    /// normals while they are set; set only while no frame is pending.
    pub fn set_shadow(&mut self, shadow: Option<super::shadow::EmbeddedShadow>) {
        self.shadow = shadow;
    }

    /// The shadows' state (the host updates `params` when its camera moves).
    pub fn shadow_mut(&mut self) -> Option<&mut super::shadow::EmbeddedShadow> {
        self.shadow.as_mut()
    }

    /// Sets the plan [`Embedder::record`] draws (kept when equal to the current one).
    /// A new plan with as many loops keeps the old loop counts as its first
    /// guess (the GPU check corrects them, see the module doc).
    pub fn set_plan(&mut self, plan: Plan) {
        if self.plan.as_ref() == Some(&plan) {
            return;
        }
        let loops = |p: &Plan| {
            p.steps
                .iter()
                .filter(|s| matches!(s, crate::plan::Step::Loop(_)))
                .count()
        };
        if let Some((old, l)) = self.layers.take() {
            if loops(&old) == loops(&plan) {
                self.layers = Some((plan.clone(), l));
            }
        }
        self.plan = Some(plan);
    }

    /// Sets the cutter sets of the current plan's scene and camera
    /// ([`CutAway::of`]): outside them [`Embedder::record`]'s final-shade
    /// pieces skip the check of the output depth. They must be those of the
    /// plan's scene, camera and algorithm: a set that misses a cutter would
    /// show faces that are cut away. [`CutAway::none`] (the default) keeps
    /// every check. The executor gets them too, for its SCS subtractions
    /// ([`Executor::set_cut_away`]).
    pub fn set_cut_away(&mut self, cut_away: CutAway) {
        self.exec.set_cut_away(cut_away.clone());
        self.cut_away = cut_away;
    }

    /// The plan [`Embedder::record`] draws.
    pub fn plan(&self) -> Option<&Plan> {
        self.plan.as_ref()
    }

    /// Runs the plan once standalone on peeltrim's queue, waiting for it, to learn
    /// its loop counts. Not part of the record path: call it when the host has no
    /// frame of this embedder pending (at load, or after a big change of view).
    pub fn prepare(&mut self) -> Result<ExecStats, VkError> {
        let _layer = self.shared.layer_use();
        let plan = self
            .plan
            .clone()
            .ok_or_else(|| VkError::Plan("prepare before set_plan".into()))?;
        let plan = &plan;
        let stats = self.exec.execute(plan)?;
        self.layers = self.exec.learnt_layers(plan).map(|l| (plan.clone(), l));
        for s in &mut self.slots {
            s.pending = None;
        }
        Ok(stats)
    }

    /// Sets the loop counts the next recordings of the current plan unroll to
    /// (one per `Step::Loop`, in plan order; each at least 1). The ring's checks
    /// correct them afterwards (see the module doc).
    pub fn set_loop_counts(&mut self, counts: Vec<u32>) -> Result<(), VkError> {
        let plan = self
            .plan
            .clone()
            .ok_or_else(|| VkError::Plan("set_loop_counts before set_plan".into()))?;
        let loops = plan
            .steps
            .iter()
            .filter(|s| matches!(s, crate::plan::Step::Loop(_)))
            .count();
        if counts.len() != loops || counts.contains(&0) {
            return Err(VkError::Plan(format!(
                "loop counts {counts:?}: the plan has {loops} loops, each needs a count of at least 1"
            )));
        }
        self.layers = Some((plan, counts));
        Ok(())
    }

    /// Whether the plan's loop counts are known ([`Embedder::prepare`] ran, or
    /// counts were carried over from an equal plan).
    pub fn prepared(&self) -> bool {
        self.plan.as_ref().is_some_and(|p| self.layers(p).is_some())
    }

    /// The loop counts the next [`Embedder::record`] of `plan` unrolls to.
    fn layers(&self, plan: &Plan) -> Option<&[u32]> {
        match &self.layers {
            Some((p, l)) if p == plan => Some(l),
            _ => None,
        }
    }

    /// Records the plan's frame into `cmd`, its final depth-equal shade drawn
    /// straight into the host's attachments under the host's depth test
    /// ([`HostPath::Direct`]), or, as the fallback ([`HostPath`] says when),
    /// into peeltrim's images and then composited by one full-screen pass.
    /// Returns the recording's counts (`submits` is 0: the host submits) and
    /// `host_path`.
    ///
    /// # Safety
    ///
    /// - `cmd` is a primary command buffer in the recording state, outside any
    ///   render pass or dynamic rendering, allocated from a pool of the context's
    ///   queue family, and submitted (by the host) to a queue of that family.
    /// - On entry the host's colour image is in `COLOR_ATTACHMENT_OPTIMAL` and its
    ///   depth image in `DEPTH_STENCIL_ATTACHMENT_OPTIMAL`; they are left in these
    ///   layouts. The host's earlier colour and depth attachment writes are made
    ///   available and visible by one barrier recorded here, from
    ///   `COLOR_ATTACHMENT_OUTPUT | EARLY/LATE_FRAGMENT_TESTS` (attachment writes)
    ///   to the same stages (attachment reads and writes). After it, one
    ///   rendering block of the host's colour and depth attachments (depth
    ///   aspect only; a stencil aspect is neither bound nor touched) reads and
    ///   writes them: the depth merge's full-screen draw and the last pass's
    ///   mesh draws (direct) or the composite's full-screen draw, colour writes
    ///   in `COLOR_ATTACHMENT_OUTPUT` and depth
    ///   tests and writes in `EARLY/LATE_FRAGMENT_TESTS`, which the host's next
    ///   use must synchronize with, as after any rendering of its own.
    /// - Peeltrim's internal images, its vertex buffer and its query pools are used
    ///   by this recording from the first command to the last (transfer, vertex,
    ///   fragment, attachment stages); the host must not touch them.
    /// - At most `frames_in_flight` (given to [`Embedder::new`]) command buffers
    ///   holding a recording of this embedder are pending at any time, all on one
    ///   queue, and their submission order is their recording order.
    /// - If the plan changed since the previous record ([`Embedder::set_plan`]
    ///   with another plan), those command buffers have completed: a new plan may
    ///   replace internal images. Likewise when the host's formats change.
    /// - The host's colour and depth formats are checked first: one peeltrim
    ///   cannot write is [`VkError::HostFormat`] with nothing recorded into `cmd`.
    /// - The views stay valid until the command buffer has completed.
    pub unsafe fn record(
        &mut self,
        cmd: vk::CommandBuffer,
        targets: &HostTargets,
    ) -> Result<ExecStats, VkError> {
        let _layer = self.shared.layer_use();
        let plan = self
            .plan
            .clone()
            .ok_or_else(|| VkError::Plan("record before set_plan".into()))?;
        let plan = &plan;
        let d = *self.exec.desc();
        // The composite's depth test: nearer wins, the CSG (drawn after the
        // host's geometry) on exact ties, as in the direct pass.
        let depth_compare = if d.reversed_z {
            vk::CompareOp::GREATER_OR_EQUAL
        } else {
            vk::CompareOp::LESS_OR_EQUAL
        };
        if targets.extent != [d.width, d.height] {
            return Err(VkError::Plan(format!(
                "host targets are {}x{}, the embedder's images {}x{}: resize the embedder to the host's targets",
                targets.extent[0], targets.extent[1], d.width, d.height
            )));
        }
        // Before anything is recorded: an unsupported format leaves `cmd` untouched.
        let formats = (targets.color_format, targets.depth_format);
        if self.host_formats != Some(formats) {
            check_host_formats(&self.shared, formats.0, formats.1)?;
            self.host_formats = Some(formats);
        }
        self.check_finished_slot(plan)?;
        let layers = self.layers(plan).map(<[u32]>::to_vec).ok_or_else(|| {
            VkError::Plan(
                "record before the loop counts are known: call set_loop_counts or prepare".into(),
            )
        })?;
        let slot = (self.frame % self.slots.len() as u64) as usize;
        let path = self.host_path(plan);
        let (unrolled, stats) = match path {
            HostPath::Direct => {
                let room = self.counts_room(slot, Executor::counted_draws(plan, &layers));
                let host = HostShade {
                    color: (targets.color_view, targets.color_format),
                    depth: (targets.depth_view, targets.depth_format),
                    srgb: is_srgb(targets.color_format),
                    samples: d.samples,
                    counts: room.then_some(self.slots[slot].counts.raw),
                    cut_away: &self.cut_away,
                };
                let shade = final_shade(plan).expect("host_path checked it");
                let unrolled =
                    self.exec
                        .record_unrolled(cmd, plan, &layers, Some((&host, shade)))?;
                let stats = unrolled.stats.clone();
                (unrolled, stats)
            }
            HostPath::CompositeShadows | HostPath::CompositePlan if d.samples > 1 => {
                return Err(VkError::Unsupported(format!(
                    "{} into a host frame of {} samples per pixel: the composite \
                     (shadows, or a plan that does not end in the final shade: \
                     blister-paper, CST with trimmed surfaces) reads single-sample \
                     images; use samples 1 or another algorithm",
                    plan.algo, d.samples
                )));
            }
            HostPath::CompositeShadows | HostPath::CompositePlan => {
                let unrolled = self.exec.record_unrolled(cmd, plan, &layers, None)?;
                let n = unrolled.groups.len() as u32;
                let counted = n > 0 && self.counts_room(slot, n);
                if counted {
                    let pool = self.exec.occlusion_pool();
                    let buffer = self.slots[slot].counts.raw;
                    copy_counts(&self.shared.device, cmd, pool, n, buffer);
                }
                if let Some(sh) = &mut self.shadow {
                    let rect = self.exec.output_rect();
                    sh.pass
                        .record(cmd, &self.exec, &sh.map, &sh.params, rect, None)?;
                }
                let mut stats = unrolled.stats.clone();
                self.composite(cmd, plan, targets, depth_compare, counted, &mut stats)?;
                (unrolled, stats)
            }
        };
        self.frame += 1;
        self.slots[slot].pending = Some((plan.clone(), unrolled));
        Ok(ExecStats {
            host_path: Some(path),
            ..stats
        })
    }

    /// How [`Embedder::record`] will draw the current plan into the host's
    /// attachments (`None`: no plan yet). A multisampled embedder records
    /// only [`HostPath::Direct`] and refuses the composite paths.
    pub fn next_host_path(&self) -> Option<HostPath> {
        self.plan.as_ref().map(|p| self.host_path(p))
    }

    /// How `record` draws `plan` into the host's attachments.
    fn host_path(&self, plan: &Plan) -> HostPath {
        if self.shadow.is_some() {
            HostPath::CompositeShadows
        } else if final_shade(plan).is_none() {
            HostPath::CompositePlan
        } else {
            HostPath::Direct
        }
    }

    /// Checks the frame that last used the slot the next frame takes: by the
    /// frames-in-flight contract it has completed.
    fn check_finished_slot(&mut self, plan: &Plan) -> Result<(), VkError> {
        let slot = (self.frame % self.slots.len() as u64) as usize;
        let Some((p, u)) = self.slots[slot].pending.take() else {
            return Ok(());
        };
        let n = u.groups.len();
        let bytes = self.slots[slot].counts.mapped()?;
        let word =
            |i: usize| u64::from_ne_bytes(bytes[i * 8..i * 8 + 8].try_into().expect("8 bytes"));
        let available = (0..n).all(|i| word(2 * i + 1) != 0);
        if p != *plan || !available {
            return Ok(());
        }
        let samples: Vec<u64> = (0..n).map(|i| word(2 * i)).collect();
        if Executor::unrolled_fits(&p, &u, &samples) {
            return Ok(());
        }
        let adjusted = adjust_layers(&u, &samples);
        if self.layers(plan) == Some(&u.layers[..]) {
            self.layers = Some((p, adjusted));
        }
        Ok(())
    }

    /// Whether `slot`'s count buffer has room for `n` occlusion counts with
    /// their availability (grown if need be; `false` for none or if it cannot
    /// grow, when the frame's counts are simply not checked).
    fn counts_room(&mut self, slot: usize, n: u32) -> bool {
        let need = (n.max(1) as u64) * 16;
        if self.slots[slot].counts.size < need {
            // Grown outside any pending use: by the frames-in-flight contract this
            // slot's last frame completed.
            match Buffer::new(
                &self.shared,
                "embed counts",
                need.next_power_of_two(),
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            ) {
                Ok(b) => self.slots[slot].counts = b,
                Err(_) => return false,
            }
        }
        n > 0
    }

    /// Draws peeltrim's colour and depth into the host's attachments, where the
    /// CSG covers the pixel, with the host's depth test, and adds its counts to
    /// `stats`. One barrier before it orders everything it reads after what
    /// wrote it (peeltrim's output images to sampled; the host's attachment
    /// writes; with `counted`, the count copy for the host's read), one after
    /// it returns the output images to `REST` for the next frame.
    fn composite(
        &mut self,
        cmd: vk::CommandBuffer,
        plan: &Plan,
        t: &HostTargets,
        depth_compare: vk::CompareOp,
        counted: bool,
        stats: &mut ExecStats,
    ) -> Result<(), VkError> {
        let formats = (t.color_format, t.depth_format);
        if self.composite.as_ref().map(|c| c.formats) != Some(formats) {
            if let Some(old) = self.composite.take() {
                // The host has no frame of the old formats pending (it changed
                // its attachments, so it waited for them).
                old.destroy(&self.shared.device);
            }
            self.composite = Some(Composite::new(&self.shared, formats)?);
        }
        // A depth texture where the plan has one (lavapipe fetches it faster).
        let depth_tex = peel_depth(plan);
        let out = self
            .exec
            .output(depth_tex)
            .expect("record_unrolled leaves an output");
        let views = [out.color.1, out.prim.1, out.depth.1];
        let c = self.composite.as_mut().expect("made above");
        if c.views != Some(views) {
            c.write_set(&self.shared, &out, self.sampler);
            c.views = Some(views);
        }
        let device = &self.shared.device;
        let images = [
            (out.color.0, vk::ImageAspectFlags::COLOR),
            (out.prim.0, vk::ImageAspectFlags::COLOR),
            (
                out.depth.0,
                match depth_tex {
                    Some(_) => vk::ImageAspectFlags::COLOR,
                    None => vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
                },
            ),
        ];
        let transition = |from: Usage, to: Usage| {
            let (src, dst) = sync::transition(from, to, false);
            let barriers: Vec<_> = images
                .iter()
                .map(|&(img, aspect)| sync::image_barrier(src, dst, img, aspect))
                .collect();
            (src.stage, dst.stage, barriers)
        };
        let (src, dst, to_sampled) = transition(REST, Usage::Sampled);
        let ((hsrc, hdst), memory) = host_barriers(counted);
        let (src, dst) = (src | hsrc, dst | hdst);
        submit::pipeline_barrier(device, cmd, (src, dst), &memory, &to_sampled);
        // Only where the CSG can be: its meshes' projected bounds.
        let rect = self.exec.output_rect();
        c.draw(device, cmd, t, crate::vk::conv::rect2d(rect), depth_compare);
        let (s, d, b) = transition(Usage::Sampled, REST);
        submit::image_barriers(device, cmd, s, d, &b);
        stats.counts.barriers += 2;
        stats.counts.fullscreen_passes += 1;
        stats.counts.fullscreen_pixels += rect.area();
        Ok(())
    }
}

/// Loop counts corrected by a frame's samples: one past the last head that
/// passed samples (the first empty head ends the loop), or twice as many when
/// even the last head passed samples.
fn adjust_layers(u: &Unrolled, samples: &[u64]) -> Vec<u32> {
    let mut per_head: Vec<Vec<u64>> = u.layers.iter().map(|&n| vec![0; n as usize]).collect();
    for (g, s) in u.groups.iter().zip(samples) {
        if let Some((l, k)) = g {
            per_head[*l][*k as usize] += s;
        }
    }
    per_head
        .iter()
        .map(|heads| match heads.iter().position(|&s| s == 0) {
            Some(first_empty) => first_empty as u32 + 1,
            None => (heads.len() as u32 * 2).max(1),
        })
        .collect()
}

impl Drop for Embedder {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
        if let Some(c) = self.composite.take() {
            c.destroy(&self.shared.device);
        }
        // SAFETY: as in `Composite::destroy`.
        unsafe { self.shared.device.destroy_sampler(self.sampler, None) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unrolled(layers: Vec<u32>, groups: Vec<Option<(usize, u32)>>) -> Unrolled {
        Unrolled {
            layers,
            groups,
            stats: ExecStats::default(),
        }
    }

    #[test]
    fn counts_shrink_to_one_past_the_last_head_with_samples() {
        // Loop 0 unrolled to 4 heads; its third head counted nothing.
        let u = unrolled(vec![4], (0..4).map(|k| Some((0, k))).collect());
        assert_eq!(adjust_layers(&u, &[9, 3, 0, 0]), vec![3]);
    }

    #[test]
    fn counts_double_when_even_the_last_head_had_samples() {
        // Two loops; the second needs more layers than it was given.
        let groups = vec![Some((0, 0)), Some((0, 1)), None, Some((1, 0)), Some((1, 1))];
        let u = unrolled(vec![2, 2], groups);
        assert_eq!(adjust_layers(&u, &[5, 0, 77, 4, 2]), vec![2, 4]);
    }
}
