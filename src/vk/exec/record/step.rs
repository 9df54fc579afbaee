//! A plan step recorded: passes (timestamps), texture copies, and draws —
//! lowered once (`record/lower.rs`), their meshes joined into one draw call
//! where nothing per mesh reaches the shaders, occlusion-counted where the
//! plan asks.

use ash::vk;

use super::{state, BlockKey, Recorder};
use crate::plan::lower::{self, RecordedDraw};
use crate::plan::usage::{self, Resource, Usage};
use crate::plan::{Draw, Fragment, Geometry, Scissor, Step};
use crate::vk::conv;
use crate::vk::error::VkError;
use crate::vk::pipeline::{FragmentKind, PushConstants};
use crate::vk::scissor::Rect;
use crate::vk::sync;

impl Recorder<'_> {
    pub fn step(&mut self, step: &Step) -> Result<(), VkError> {
        self.next += 1;
        match step {
            Step::Pass(name) => {
                self.stats.pass_entry(name);
                self.pass = self.stats.per_pass.iter().position(|p| &p.name == name);
                if self.b.pass_timestamps {
                    // Lavapipe ends its binned scene at a timestamp (and bins the
                    // query into every tile): only when per-pass times are asked for.
                    self.end_block();
                    self.timestamp(name.clone(), vk::PipelineStageFlags::BOTTOM_OF_PIPE);
                }
            }
            Step::Clear(clear) => self.clear(clear),
            Step::CopyTexture { src, dst } => {
                self.copy_image(step, Resource::Texture(*src), Resource::Texture(*dst))
            }
            Step::CopyDepthBound { src, dst } => self.copy_image(
                step,
                Resource::DepthStencil(*src),
                Resource::DepthStencil(*dst),
            ),
            Step::CopyDepthToTexture { ds, dst } => self.copy_depth(step, *ds, *dst)?,
            Step::Draw(draw) => self.draw(draw)?,
            Step::Loop(_) => {
                panic!("loops are unrolled by the executor (plan::validate forbids nesting)")
            }
        }
        Ok(())
    }

    /// `Step::CopyTexture` or `Step::CopyDepthBound`: image `src` into `dst`
    /// (same format), every aspect, where later steps read it (`plan::reach`).
    fn copy_image(&mut self, step: &Step, src: Resource, dst: Resource) {
        let rect = self.copy_region();
        if src == dst || rect.is_empty() {
            // Nobody reads the copy.
            self.stats.counts.skipped_steps += u64::from(src != dst);
            return;
        }
        let uses = step.usage();
        self.settle_clears(&uses);
        self.transitions(&uses, false);
        self.end_block();
        let (s, d) = (self.b.targets.image(src), self.b.targets.image(dst));
        let layers = vk::ImageSubresourceLayers {
            aspect_mask: s.desc.aspect(),
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        };
        let offset = vk::Offset3D {
            x: rect.x0 as i32,
            y: rect.y0 as i32,
            z: 0,
        };
        let region = vk::ImageCopy {
            src_subresource: layers,
            src_offset: offset,
            dst_subresource: layers,
            dst_offset: offset,
            extent: vk::Extent3D {
                width: rect.width(),
                height: rect.height(),
                depth: 1,
            },
        };
        self.stats.counts.copied_pixels += rect.area();
        // SAFETY: outside rendering; both images allow transfer, same format,
        // in the copy layouts after the barrier above; the region lies in both.
        unsafe {
            self.b.device.cmd_copy_image(
                self.cmd,
                s.raw,
                sync::access(Usage::CopySrc).layout,
                d.raw,
                sync::access(Usage::CopyDst).layout,
                &[region],
            )
        };
    }

    /// A draw's scissor lies in its block's render area (`render_area`).
    pub(super) fn check_in_area(&self, scissor: Rect) {
        assert!(
            self.render_area.contains(&scissor),
            "a draw's scissor {scissor:?} lies outside its block's render area {:?}",
            self.render_area
        );
    }

    pub(super) fn scissor(&self, s: &Scissor) -> Rect {
        let (w, h) = (self.b.desc.width, self.b.desc.height);
        self.b.mesh_rects.scissor(s, w, h)
    }

    fn draw(&mut self, draw: &Draw) -> Result<(), VkError> {
        // One lowering, shared with the look-ahead (`record/lower.rs`).
        let dead = self.dead_texture_write(draw);
        let scissor = self.scissor(&draw.scissor);
        match lower::lower(draw, dead, scissor, self.b.ties, &self.direct) {
            RecordedDraw::OffScreen => {
                self.stats.counts.skipped_steps += 1;
                Ok(())
            }
            RecordedDraw::Dropped => Ok(()),
            RecordedDraw::One(d, how) => {
                if !self.draw_seen(&d, how, scissor)? {
                    self.stats.counts.skipped_steps += 1;
                }
                Ok(())
            }
            RecordedDraw::Zoned {
                rule,
                culled,
                fixed,
                zones,
            } => self.zoned_shade(&rule, culled, &fixed, scissor, zones),
        }
    }

    /// Records `draw`, lowered `how`, cut to `scissor` and, for a cavity's
    /// inside, to where it can be seen (`lower::seen_inside`), counting it;
    /// `false` where nothing of it is left to record.
    pub(super) fn draw_seen(
        &mut self,
        draw: &Draw,
        how: lower::Lowering,
        scissor: Rect,
    ) -> Result<bool, VkError> {
        let seen = lower::seen_inside(draw, how, scissor, &self.b.mesh_rects);
        self.stats.counts.shade_insides_cut_pixels += scissor.area() - seen.area();
        if seen.is_empty() {
            return Ok(false);
        }
        self.stats.counts.count_lowering(how, draw, seen);
        self.draw_in(draw, seen)?;
        Ok(true)
    }

    /// Records `draw` cut to `scissor`, not empty.
    pub(super) fn draw_in(&mut self, draw: &Draw, scissor: Rect) -> Result<(), VkError> {
        let kind = fragment_kind(&draw.fragment);
        let set = usage::sampled_texture(&draw.fragment)
            .map(|t| self.b.targets.sampling_set(Resource::Texture(t)));
        let mut uses = self.draw_uses(draw);
        let own = BlockKey::of_draw(&uses, draw.ds);
        let key = self.block_for(own, kind.writes_color(), scissor, &uses);
        if key != own {
            // Attached though not written (masked): a new block needs their
            // barriers too.
            for &c in key.colors() {
                uses.push((c, Usage::ColorTarget));
            }
        }
        let raster = state::raster_state(Some(draw), self.b.desc.reversed_z);
        let pipe = self.pipeline_for(&key, kind, &raster)?;
        self.open(&key, &uses);
        self.check_in_area(scissor);
        self.bind_pipe(pipe, set);
        self.set_draw_scissor(&draw.geometry, scissor);
        let flags = self.flags();
        let scene = self.b.scene;
        let rgb = |c: [u8; 3]| {
            [
                c[0] as f32 / 255.0,
                c[1] as f32 / 255.0,
                c[2] as f32 / 255.0,
                1.0,
            ]
        };
        let device = self.b.device;
        let query = if draw.count_samples {
            let q = self.queries.len() as u32;
            self.queries.push(self.group);
            // SAFETY: inside a block; the query was reset in this buffer and is not active.
            unsafe {
                device.cmd_begin_query(
                    self.cmd,
                    self.b.occlusion,
                    q,
                    vk::QueryControlFlags::empty(),
                )
            };
            Some(q)
        } else {
            None
        };
        self.stats.counts.draws += 1;
        if let Some(i) = self.pass {
            self.stats.per_pass[i].draws += 1;
        }
        match &draw.geometry {
            Geometry::FullScreen { depth } => {
                let color = match draw.fragment {
                    Fragment::Paint { rgb: c } => rgb(c),
                    _ => rgb(scene.background),
                };
                let pc = PushConstants {
                    mvp: Self::fullscreen_matrix(conv::depth_value(*depth, self.b.desc.reversed_z)),
                    color,
                    prim: 0,
                    flags,
                    // The quad stays unsnapped (`shaders/mesh.vert`).
                    snap: self.b.snap,
                    ..Default::default()
                };
                self.quad_pass(kind, &pc, scissor.area());
            }
            Geometry::Mesh(_) | Geometry::Meshes(_) | Geometry::Footprint { .. } => {
                let ids = draw.geometry.meshes();
                let (w, h) = (self.b.desc.width, self.b.desc.height);
                if let Geometry::Footprint { depth, .. } = draw.geometry {
                    // Every fragment at `depth`; clipping is the mesh's own.
                    let d = conv::depth_value(depth, self.b.desc.reversed_z);
                    state::set_viewport(device, self.cmd, w, h, d..=d);
                    self.stats.counts.state_commands += 1;
                    self.stats.counts.footprint_passes += 1;
                }
                self.stats.counts.mesh_draws += 1;
                self.stats.counts.mesh_pixels += scissor.area();
                // A program that reads the primitive id needs each mesh's own
                // constants and draw call.
                let per_mesh = kind.reads().prim;
                let mut i = 0;
                while i < ids.len() {
                    let m = ids[i];
                    let (first, mut count) = scene.ranges[m as usize];
                    // Meshes that follow in the vertex buffer join this call when
                    // nothing per mesh reaches the shaders.
                    let mut j = i + 1;
                    while !per_mesh && j < ids.len() && ids[j] == ids[j - 1] + 1 {
                        count += scene.ranges[ids[j] as usize].1;
                        j += 1;
                    }
                    // Fields the program does not read are not pushed for.
                    let (color, prim) = if per_mesh {
                        let color = match draw.fragment {
                            Fragment::Paint { rgb: c } => rgb(c),
                            Fragment::Background => rgb(scene.background),
                            // The tolerance travels in the colour's alpha.
                            Fragment::ShadeNearDepth { eps, .. } => {
                                let [r, g, b, _] = rgb(scene.colors[m as usize]);
                                [r, g, b, eps]
                            }
                            _ => rgb(scene.colors[m as usize]),
                        };
                        (color, m + 1)
                    } else {
                        let color = match draw.fragment {
                            Fragment::PeelTolerant { eps, .. } => [eps, 0.0, 0.0, 0.0],
                            Fragment::NearerThan { eps, .. }
                            | Fragment::ParityBeforeExit { eps, .. }
                            | Fragment::BehindThan { eps, .. }
                            | Fragment::TieDepth { eps }
                            | Fragment::MergeBehind { eps, .. } => [0.0, 0.0, 0.0, eps],
                            _ => [0.0; 4],
                        };
                        (color, 0)
                    };
                    let pc = PushConstants {
                        color,
                        prim,
                        // The matrix comes from the camera's uniform buffer.
                        flags,
                        snap: self.b.snap,
                        ..Default::default()
                    };
                    self.push_for(kind, false, &pc);
                    self.draw_corners(kind.interpolated(), first, count);
                    self.stats.counts.triangles += count as u64 / 3;
                    i = j;
                }
                if let Geometry::Footprint { .. } = draw.geometry {
                    state::set_viewport(device, self.cmd, w, h, 0.0..=1.0);
                    self.stats.counts.state_commands += 1;
                }
            }
        }
        if let Some(q) = query {
            // SAFETY: the query was begun in this block.
            unsafe { device.cmd_end_query(self.cmd, self.b.occlusion, q) };
        }
        Ok(())
    }
}

impl Recorder<'_> {
    /// Draws the corners `first..first + count` (a range of whole triangles
    /// of `GpuScene::ranges`) for a program that reads interpolated
    /// outputs (`lit`: `FragmentKind::interpolated`) or not: indexed from the
    /// lit or the shared corners (`GpuScene`'s doc: the same triangles both
    /// ways).
    pub(super) fn draw_corners(&mut self, lit: bool, first: u32, count: u32) {
        if count == 0 {
            return;
        }
        let device = self.b.device;
        let offset = match lit {
            true => self.b.scene.lit_offset,
            false => 0,
        };
        // SAFETY: inside a block; the range lies in the index buffer
        // (`begin_state` bound it), its indices in the vertex buffer.
        unsafe { device.cmd_draw_indexed(self.cmd, count, 1, first + offset, 0, 0) };
        self.stats.counts.indexed_draw_calls += 1;
        self.stats.counts.draw_calls += 1;
    }
}

fn fragment_kind(f: &Fragment) -> FragmentKind {
    match f {
        Fragment::None => FragmentKind::None,
        Fragment::Shade => FragmentKind::Shade,
        Fragment::Paint { .. } => FragmentKind::Paint,
        Fragment::Background => FragmentKind::Background,
        Fragment::Peel { shade: true, .. } => FragmentKind::PeelShade,
        Fragment::Peel { .. } => FragmentKind::Peel,
        Fragment::WriteDepth { .. } => FragmentKind::WriteDepth,
        Fragment::ShadeAtDepth { .. } => FragmentKind::ShadeAtDepth,
        Fragment::DepthFromTexture { .. } => FragmentKind::DepthFromTexture,
        Fragment::PeelTolerant { .. } => FragmentKind::PeelTolerant,
        // The texel copy is the depth-copy shader reading a depth texture.
        Fragment::CopyTexel { .. } => FragmentKind::CopyDepth,
        Fragment::NearerThan { .. } | Fragment::ParityBeforeExit { .. } => FragmentKind::NearerThan,
        Fragment::BehindThan { .. } => FragmentKind::BehindThan,
        Fragment::TieDepth { .. } => FragmentKind::TieDepth,
        // An exact merge needs none of the tie rule's fetches.
        Fragment::MergeBehind { eps, .. } if *eps == 0.0 => FragmentKind::MergeBehindExact,
        Fragment::MergeBehind { .. } => FragmentKind::MergeBehind,
        Fragment::ShadeNearDepth { .. } => FragmentKind::ShadeNearDepth,
        Fragment::DepthAtDepth { .. } => FragmentKind::DepthAtDepth,
    }
}
