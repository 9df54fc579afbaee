//! Full-screen passes of a recording: the quad draw, internal full-screen
//! draws (depth copies), and the extension passes on a finished frame — Kirsch,
//! Nienhaus & Döllner §5.1's edge map and Hable & Rossignac §6's front-to-back
//! accumulation.

use ash::vk;

use super::clears::PendingClear;
use super::{state, targets, BlockKey, Recorder};
use crate::plan::usage::{Resource, Usage};
use crate::vk::error::VkError;
use crate::vk::exec::whole_image_region;
use crate::vk::pipeline::{FragmentKind, PushConstants, QUAD_INSTANCE};
use crate::vk::scissor::Rect;
use crate::vk::sync;

impl Recorder<'_> {
    /// Kirsch, Nienhaus & Döllner §5.1's edge map of the last frame's first layer, in
    /// one full-screen draw (`shaders/edges.frag`) into the edge target, sampling the
    /// normal buffer and depth-stencil `output_ds`; every image rests in `REST`
    /// after. `rule`: relative depth threshold and cosine of the crease angle.
    pub fn edge_pass(
        &mut self,
        cmd: vk::CommandBuffer,
        output_ds: u8,
        rule: [f32; 2],
    ) -> Result<(), VkError> {
        self.begin_state(cmd);
        let depth = Resource::DepthStencil(output_ds);
        let key = BlockKey::new(&[Resource::Edges], None);
        let uses = [
            (Resource::Edges, Usage::ColorTarget),
            (Resource::Normal, Usage::Sampled),
            (depth, Usage::Sampled),
        ];
        self.open(&key, &uses);
        let tests_off = state::raster_state(None, self.b.desc.reversed_z);
        let pipe = self.pipeline_for(&key, FragmentKind::Edges, &tests_off)?;
        self.bind_pipe(pipe, Some(self.b.targets.sampling_set(Resource::Normal)));
        let depth_set = self.b.targets.sampling_set(depth);
        // SAFETY: set 2 of the pipeline layout has the set's layout; inside a block.
        unsafe {
            self.b.device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.b.pipelines.layout,
                2,
                &[depth_set],
                &[],
            )
        };
        let full = Rect::full(self.b.desc.width, self.b.desc.height);
        self.set_scissor(full);
        let cam = &self.b.scene.camera;
        let ortho = matches!(
            cam.projection,
            crate::scene::Projection::Orthographic { .. }
        );
        let pc = PushConstants {
            mvp: Self::fullscreen_matrix(0.0),
            view: [cam.near as f32, cam.far as f32, ortho as u32 as f32, 0.0],
            color: [rule[0], rule[1], 0.0, 0.0],
            flags: self.flags(),
            snap: self.b.snap,
            ..Default::default()
        };
        self.quad_pass(FragmentKind::Edges, &pc, full.area());
        self.end_block();
        self.rest_all();
        Ok(())
    }

    /// Hable & Rossignac §6's front-to-back composite of one peeled layer, in one
    /// full-screen draw (`shaders/accumulate.frag`) blended into the
    /// accumulation target: where the layer's primitive id `p` is not 0,
    /// `C += (1 − A)·a·c` and `A += (1 − A)·a` with `a` the opacity table's
    /// entry for `p`. `table`: the first layer of a composite, which starts the
    /// target from zero and uploads the opacity table (a staging buffer of
    /// `ALPHA_TABLE_SIDE`² floats). Every image rests in `REST` after.
    pub fn accumulate_pass(
        &mut self,
        cmd: vk::CommandBuffer,
        table: Option<&crate::vk::memory::Buffer>,
    ) -> Result<(), VkError> {
        self.begin_state(cmd);
        if let Some(buf) = table {
            self.transitions(&[(Resource::AlphaTable, Usage::CopyDst)], false);
            let side = targets::ALPHA_TABLE_SIDE;
            let region = whole_image_region(vk::ImageAspectFlags::COLOR, 0, side, side);
            let img = self.b.targets.image(Resource::AlphaTable);
            // SAFETY: outside rendering; the buffer holds side² f32 and lives
            // until the caller's wait; the image is in the copy layout.
            unsafe {
                self.b.device.cmd_copy_buffer_to_image(
                    cmd,
                    buf.raw,
                    img.raw,
                    sync::access(Usage::CopyDst).layout,
                    &[region],
                )
            };
            // Read whole by the full-screen composite.
            self.pending_clear.insert(
                Resource::Accum,
                PendingClear {
                    value: vk::ClearValue {
                        color: vk::ClearColorValue { float32: [0.0; 4] },
                    },
                    rect: Rect::full(self.b.desc.width, self.b.desc.height),
                },
            );
        }
        let key = BlockKey::new(&[Resource::Accum], None);
        let uses = [
            (Resource::Accum, Usage::ColorTarget),
            (Resource::Color, Usage::Sampled),
            (Resource::Prim, Usage::Sampled),
            (Resource::AlphaTable, Usage::Sampled),
        ];
        self.open(&key, &uses);
        let t = self.b.targets;
        let sets = [
            t.sampling_set(Resource::Prim),
            t.sampling_set(Resource::AlphaTable),
        ];
        // SAFETY: sets 2 and 3 of the pipeline layout have the sets' layout;
        // inside a block.
        unsafe {
            self.b.device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.b.pipelines.layout,
                2,
                &sets,
                &[],
            )
        };
        let color_set = t.sampling_set(Resource::Color);
        let full = Rect::full(self.b.desc.width, self.b.desc.height);
        self.fullscreen_internal(&key, FragmentKind::Accumulate, color_set, full)?;
        self.end_block();
        self.rest_all();
        Ok(())
    }

    /// Pushes `pc` for `kind` and draws the full-screen quad (inside a block,
    /// with the pipeline bound), counted as a full-screen pass over `area`
    /// pixels (its scissor).
    pub(super) fn quad_pass(&mut self, kind: FragmentKind, pc: &PushConstants, area: u64) {
        self.push_for(kind, true, pc);
        let first = self.b.scene.quad_first;
        // SAFETY: inside a block with a bound pipeline and vertex buffer; the
        // quad's six vertices lie in it.
        unsafe { self.b.device.cmd_draw(self.cmd, 6, 1, first, QUAD_INSTANCE) };
        self.stats.counts.fullscreen_passes += 1;
        self.stats.counts.fullscreen_pixels += area;
    }

    pub(super) fn flags(&self) -> u32 {
        self.b.flags
    }

    pub(super) fn fullscreen_matrix(depth: f32) -> [f32; 16] {
        let mut m = glam::Mat4::IDENTITY.to_cols_array();
        m[10] = 0.0;
        m[14] = depth;
        m
    }

    /// A full-screen draw that is not a plan `Draw` (depth copies), cut to
    /// `rect`.
    pub(super) fn fullscreen_internal(
        &mut self,
        key: &BlockKey,
        kind: FragmentKind,
        set: vk::DescriptorSet,
        rect: Rect,
    ) -> Result<(), VkError> {
        let tests_off = state::raster_state(None, self.b.desc.reversed_z);
        let pipe = self.pipeline_for(key, kind, &tests_off)?;
        self.bind_pipe(pipe, Some(set));
        self.check_in_area(rect);
        self.set_scissor(rect);
        let pc = PushConstants {
            mvp: Self::fullscreen_matrix(0.0),
            flags: self.flags(),
            snap: self.b.snap,
            ..Default::default()
        };
        self.quad_pass(kind, &pc, rect.area());
        Ok(())
    }
}
