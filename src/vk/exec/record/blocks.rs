//! Rendering blocks and barriers of a recording (docs/executor.md): each
//! image's last usage, the one pipeline barrier a step's usages need
//! (`vk::sync`'s table), and the dynamic-rendering block a draw records into,
//! its load ops taking the pending clears.

use ash::vk;

use super::{BlockKey, Recorder, MAX_COLORS};
use crate::plan::usage::{Resource, Usage, Uses};
use crate::vk::conv;
use crate::vk::submit;
use crate::vk::sync::{self, REST};

/// Each image's last usage in the recording: a flat table by [`ImageStates::slot`]
/// (the recorder looks up every used image at every draw).
#[derive(Default)]
pub(super) struct ImageStates(Vec<Option<Usage>>);

impl ImageStates {
    fn slot(r: Resource) -> usize {
        match r {
            Resource::Color => 0,
            Resource::Prim => 1,
            Resource::Normal => 2,
            Resource::Edges => 3,
            Resource::Accum => 4,
            Resource::AlphaTable => 5,
            Resource::DepthStencil(d) => 6 + 2 * d as usize,
            Resource::Texture(t) => 7 + 2 * t as usize,
        }
    }

    pub(super) fn get(&self, r: Resource) -> Usage {
        self.0
            .get(Self::slot(r))
            .copied()
            .flatten()
            .unwrap_or_else(|| panic!("{r:?} is not an image of the executor's targets"))
    }

    pub(super) fn set(&mut self, r: Resource, u: Usage) {
        let i = Self::slot(r);
        if self.0.len() <= i {
            self.0.resize(i + 1, None);
        }
        self.0[i] = Some(u);
    }
}

impl Recorder<'_> {
    /// Every image to `REST`, where frames leave them.
    pub(super) fn rest_all(&mut self) {
        let rest: Vec<_> = self
            .b
            .targets
            .all()
            .into_iter()
            .map(|r| (r, REST))
            .collect();
        self.transitions(&rest, false);
    }

    pub(super) fn end_block(&mut self) {
        if self.block.take().is_some() {
            // SAFETY: a rendering block is open in this command buffer.
            unsafe { self.b.device.cmd_end_rendering(self.cmd) };
        }
    }

    /// Barriers that bring each `(resource, usage)` from its last usage; ends the
    /// open block when one is needed. `same_block`: the step records into the open
    /// block. `discarded`: resources whose contents a pending clear discards
    /// (`Recorder::clear_discards`). Returns whether a barrier was recorded.
    pub(super) fn transitions(&mut self, uses: &[(Resource, Usage)], same_block: bool) -> bool {
        self.transitions_with(uses, same_block, &[])
    }

    pub(super) fn transitions_with(
        &mut self,
        uses: &[(Resource, Usage)],
        same_block: bool,
        discarded: &[Resource],
    ) -> bool {
        let (stages, barriers) = self.image_transitions(uses, same_block, discarded);
        if barriers.is_empty() {
            return false;
        }
        self.end_block();
        submit::image_barriers(self.b.device, self.cmd, stages.0, stages.1, &barriers);
        self.stats.counts.barriers += 1;
        true
    }

    /// The image barriers (and their source and destination stages) that bring
    /// each `(resource, usage)` from its last usage, now noted as its usage;
    /// the caller records them.
    pub(super) fn image_transitions(
        &mut self,
        uses: &[(Resource, Usage)],
        same_block: bool,
        discarded: &[Resource],
    ) -> (
        (vk::PipelineStageFlags, vk::PipelineStageFlags),
        Vec<vk::ImageMemoryBarrier<'static>>,
    ) {
        let mut barriers = Vec::new();
        let (mut src_stage, mut dst_stage) = (
            vk::PipelineStageFlags::empty(),
            vk::PipelineStageFlags::empty(),
        );
        for &(r, u) in uses {
            let prev = self.state.get(r);
            if !sync::needs_barrier(prev, u, same_block) {
                continue;
            }
            let discard = u.discards() || discarded.contains(&r);
            let (src, dst) = sync::transition(prev, u, discard);
            src_stage |= src.stage;
            dst_stage |= dst.stage;
            let img = self.b.targets.image(r);
            barriers.push(sync::image_barrier(src, dst, img.raw, img.desc.aspect()));
        }
        for &(r, u) in uses {
            self.state.set(r, u);
        }
        ((src_stage, dst_stage), barriers)
    }

    /// Makes `key` the open block with every usage in `uses` satisfied.
    pub(super) fn open(&mut self, key: &BlockKey, uses: &[(Resource, Usage)]) {
        self.settle_clears(uses);
        // A pending clear opens a new block; its barrier discards the
        // image's contents only where nothing outside the region is kept.
        let (mut cleared, mut discarded) = (false, Uses::<Resource>::default());
        for &(r, _) in uses {
            if let Some(c) = self.pending_clear.get(&r) {
                cleared = true;
                if self.clear_discards(r, c) {
                    discarded.push(r);
                }
            }
        }
        let same = self.block.as_ref() == Some(key) && !cleared;
        let barrier = self.transitions_with(uses, same, &discarded);
        if same && !barrier {
            return;
        }
        self.end_block();
        self.begin_block(key);
    }

    pub(super) fn begin_block(&mut self, key: &BlockKey) {
        let color_layout = sync::access(Usage::ColorTarget).layout;
        let ds_layout = sync::access(Usage::DepthStencilTarget).layout;
        let attached = key.colors().iter().copied();
        let area = self.render_area(attached.chain(key.ds.map(Resource::DepthStencil)));
        let mut in_block = Vec::new();
        let mut attachment = |rec: &mut Self, r: Resource, index, layout| {
            let (load, clear) = rec.load_op(r, index, area, &mut in_block);
            vk::RenderingAttachmentInfo::default()
                .image_view(rec.b.targets.image(r).view)
                .image_layout(layout)
                .load_op(load)
                .clear_value(clear)
                .store_op(vk::AttachmentStoreOp::STORE)
        };
        let mut colors = [vk::RenderingAttachmentInfo::default(); MAX_COLORS];
        for (i, (a, r)) in colors.iter_mut().zip(key.colors()).enumerate() {
            *a = attachment(self, *r, Some(i as u32), color_layout);
        }
        let colors = &colors[..key.n_colors as usize];
        let ds_att = key
            .ds
            .map(|d| attachment(self, Resource::DepthStencil(d), None, ds_layout));
        let mut ri = vk::RenderingInfo::default()
            .render_area(conv::rect2d(area))
            .layer_count(1)
            .color_attachments(colors);
        if let Some(a) = ds_att.as_ref() {
            ri = ri.depth_attachment(a);
            if conv::has_stencil(self.b.targets.ds_format) {
                ri = ri.stencil_attachment(a);
            }
        }
        // SAFETY: recording outside rendering; all views are live and, after the
        // recorder's barriers, in the attachment layouts given.
        unsafe { self.b.device.cmd_begin_rendering(self.cmd, &ri) };
        self.stats.counts.render_passes += 1;
        self.block = Some(*key);
        self.render_area = area;
        self.clear_in_block(&in_block);
    }
}
