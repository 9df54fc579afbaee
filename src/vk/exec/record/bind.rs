//! What a recording binds and sets (≤ 1 µs of CPU per draw):
//! pipelines found without building a `PipelineDesc` per draw, descriptor
//! sets, scissors, dynamic state and push constants, each recorded only where
//! it changes (`state.rs`, `record/push.rs`).

use ash::vk;

use super::{state, targets, BlockKey, Recorder};
use crate::plan::usage::Resource;
use crate::plan::{Draw, Geometry};
use crate::vk::conv;
use crate::vk::error::VkError;
use crate::vk::pipeline::{FragmentKind, PipelineDesc, PushConstants, RasterState, Reads};
use crate::vk::scissor::Rect;

/// A pipeline of a recording: what selects it, and whether its depth,
/// stencil and cull state is baked in (`fixed`) or set dynamically.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pipe {
    block: BlockKey,
    kind: FragmentKind,
    state: RasterState,
    pipeline: vk::Pipeline,
    fixed: bool,
}

impl Recorder<'_> {
    /// The pipeline of fragment program `kind` in block `key` with `state`
    /// baked in, or with dynamic state past the executor's budget of variants
    /// (`vk::pipeline::MAX_FIXED_PIPELINES`).
    pub(super) fn pipeline_for(
        &mut self,
        key: &BlockKey,
        kind: FragmentKind,
        state: &RasterState,
    ) -> Result<Pipe, VkError> {
        let hit = |p: &Pipe| p.kind == kind && p.state == *state && p.block == *key;
        // The last two used first: consecutive draws mostly repeat or
        // alternate (a trim's mesh draw and sweep).
        for &i in &self.recent {
            if self.pipes.get(i).is_some_and(hit) {
                return Ok(self.pipes[i]);
            }
        }
        if let Some(i) = self.pipes.iter().position(hit) {
            self.recent = [i, self.recent[0]];
            return Ok(self.pipes[i]);
        }
        let desc = PipelineDesc {
            fragment: kind,
            color_formats: key.colors().iter().map(|r| targets::format(*r)).collect(),
            depth_stencil_format: key.ds.map(|_| self.b.targets.ds_format),
            // A program that writes no colour runs as is, the normal buffer
            // masked with the other attachments.
            normals: kind.writes_color() && key.colors().contains(&Resource::Normal),
            samples: self.b.desc.samples,
        };
        let (pipeline, fixed) = match self.b.pipelines.get_fixed(&desc, state)? {
            Some(p) => (p, true),
            None => (self.b.pipelines.get(&desc)?, false),
        };
        let pipe = Pipe {
            block: *key,
            kind,
            state: *state,
            pipeline,
            fixed,
        };
        self.pipes.push(pipe);
        self.recent = [self.pipes.len() - 1, self.recent[0]];
        Ok(pipe)
    }

    /// Binds `pipe` and `set` where they differ from what is bound, and sets
    /// the pipe's state dynamically when it is not baked in.
    pub(super) fn bind_pipe(&mut self, pipe: Pipe, set: Option<vk::DescriptorSet>) {
        if pipe.fixed {
            if self.bound != Some(pipe.pipeline) {
                // Its static state leaves the dynamic state undefined.
                self.dyn_state = None;
            }
            self.bind(pipe.pipeline, set);
        } else {
            self.bind(pipe.pipeline, set);
            self.set_dynamic(&pipe.state);
        }
    }

    /// Binds `pipeline` and `set` where they differ from what is bound.
    pub(super) fn bind(&mut self, pipeline: vk::Pipeline, set: Option<vk::DescriptorSet>) {
        let device = self.b.device;
        if self.bound != Some(pipeline) {
            // SAFETY: recording inside a block whose formats match the pipeline.
            unsafe {
                device.cmd_bind_pipeline(self.cmd, vk::PipelineBindPoint::GRAPHICS, pipeline)
            };
            self.bound = Some(pipeline);
            self.stats.counts.state_commands += 1;
        }
        if let Some(set) = set.filter(|&s| self.bound_set != Some(s)) {
            // SAFETY: the set matches the pipeline layout's set 0.
            unsafe {
                device.cmd_bind_descriptor_sets(
                    self.cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.b.pipelines.layout,
                    0,
                    &[set],
                    &[],
                )
            };
            self.bound_set = Some(set);
            self.stats.counts.state_commands += 1;
        }
    }

    /// Sets the scissor unless it is what is set.
    pub(super) fn set_scissor(&mut self, scissor: Rect) {
        if self.scissor != Some(scissor) {
            // SAFETY: recording; every pipeline declares the scissor dynamic.
            unsafe {
                self.b
                    .device
                    .cmd_set_scissor(self.cmd, 0, &[conv::rect2d(scissor)])
            };
            self.scissor = Some(scissor);
            self.stats.counts.state_commands += 1;
        }
    }

    /// Sets the scissor of a draw of `geometry` that asks for `scissor`,
    /// unless the one set cuts its meshes alike (`state::scissor_serves`).
    pub(super) fn set_draw_scissor(&mut self, geometry: &Geometry, scissor: Rect) {
        if self.scissor == Some(scissor) {
            return;
        }
        let ids = match geometry {
            Geometry::FullScreen { .. } => return self.set_scissor(scissor),
            g => g.meshes(),
        };
        let kept = self.scissor.is_some_and(|c| {
            let covered = self.b.mesh_rects.of(ids);
            state::scissor_serves(c, scissor, covered, self.render_area)
        });
        if !kept {
            self.set_scissor(scissor);
        }
    }

    /// Records the fields of `next` that differ from the dynamic state set (a
    /// pipeline with dynamic depth, stencil and cull state is bound).
    fn set_dynamic(&mut self, next: &RasterState) {
        let mut n = 0;
        for f in state::changes(next, self.dyn_state.as_ref()) {
            state::record(self.b.device, self.cmd, next, f);
            n += 1;
        }
        self.stats.counts.state_commands += n;
        self.dyn_state = Some(*next);
    }

    /// Sets the scissor and the dynamic state of `draw` (`None`: tests off),
    /// under a pipeline with dynamic state ([`Pipelines::get`]).
    pub(super) fn set_state(&mut self, draw: Option<&Draw>, scissor: Rect) {
        self.set_scissor(scissor);
        self.set_dynamic(&state::raster_state(draw, self.b.desc.reversed_z));
    }

    /// Records `pc` unless what the command buffer holds serves a draw that
    /// reads every field.
    pub(super) fn push(&mut self, pc: &PushConstants) {
        self.push_reads(pc, Reads::ALL);
    }

    /// Records `pc` for a draw of program `kind` (`quad`: of the full-screen
    /// quad, which reads `mvp`) unless what is held serves it (`record/push.rs`).
    pub(super) fn push_for(&mut self, kind: FragmentKind, quad: bool, pc: &PushConstants) {
        let reads = Reads {
            mvp: quad,
            ..kind.reads()
        };
        self.push_reads(pc, reads);
    }

    fn push_reads(&mut self, pc: &PushConstants, reads: Reads) {
        let Some(next) = self.push.next(pc, reads) else {
            return;
        };
        // SAFETY: recording; the range matches the layout's single push range.
        unsafe {
            self.b.device.cmd_push_constants(
                self.cmd,
                self.b.pipelines.layout,
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                0,
                &next.bytes(),
            )
        };
        self.stats.counts.state_commands += 1;
    }
}
