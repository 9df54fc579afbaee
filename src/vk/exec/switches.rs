//! The executor's switches (`set_*`): settings that choose how a plan is
//! recorded — clears, block joins, timestamps, the tie-free draws, depth-only
//! images, the emulated vertex snapping — and the push-constant flags they
//! imply. Each drops the kept recording where it changes what is recorded
//! (README "Executor"; the A/B switches are measured in README "Per-pixel cost"
//! and "The final shade as depth-equal draws").

use super::{BlockJoin, ClearMode, DepthFormat, Executor, FrameTimestamps};
use crate::plan::cut_away::CutAway;
use crate::vk::error::VkError;
use crate::vk::pipeline::{pipeline_flags, FLAG_RASTER_DEPTH};

impl Executor {
    /// Emulates a coarser device's vertex snapping in every later mesh draw.
    pub fn set_rounding_emulation(&mut self, rounding: Option<crate::vk::RoundingEmulation>) {
        self.rounding = rounding;
        self.recording = None;
    }

    /// The push constants' flags: reversed Z, and the subpixel precision the tie
    /// tolerance assumes ([`Self::subpixel_bits`]).
    pub(super) fn flags(&self) -> u32 {
        let raster = match self.depth_equal_shades() {
            true => FLAG_RASTER_DEPTH,
            false => 0,
        };
        pipeline_flags(self.desc.reversed_z, self.subpixel_bits()) | raster
    }

    /// Whether final shades run depth-equal draws where no tie is possible
    /// ([`Self::set_fixed_shade`]).
    pub(super) fn depth_equal_shades(&self) -> bool {
        // D24: lavapipe's raster depth, quantized, misses the strict depth
        // bar of `vk_tests` `classic_assembly` (p99 4.3e-6 against 3.8e-6 view
        // units), where the plane depth at the pixel centre meets it.
        let d32 = self.desc.depth_format == DepthFormat::D32S8;
        self.tie_free && self.fixed_shade && self.unsnapped && self.rounding.is_none() && d32
    }

    /// The vertex snapping the tie rule allows for: the device's, or the
    /// emulated device's.
    pub(super) fn subpixel_bits(&self) -> u32 {
        match self.rounding {
            Some(r) => r.subpixel_bits,
            None => self.shared.limits.sub_pixel_precision_bits,
        }
    }

    /// Whether tolerant parity and peel draws whose meshes cannot tie under the
    /// current camera run as plain depth tests (`plan::tie_free`; the default).
    /// Off: every one runs its tie-rule shader (A/B measurements). Both give the
    /// same images up to crossings of faces within a depth quantum.
    pub fn set_tie_free(&mut self, on: bool) {
        self.tie_free = on;
        self.recording = None;
    }

    /// Whether the final shade's draws of meshes that cannot tie run as plain
    /// depth-`EQUAL` draws (`plan::tie_free`; the default, with
    /// [`Self::set_tie_free`] on). Off: they keep the tie rule (A/B
    /// measurements). Only on a device that does not snap vertices before
    /// interpolating depth (lavapipe; not under the rounding emulation): a
    /// depth-equal shade leaves the raster depth in the depth output, which
    /// carries the snapping error that the tie rule's plane depth removes
    /// (README "The final shade as depth-equal draws").
    pub fn set_fixed_shade(&mut self, on: bool) {
        self.fixed_shade = on;
        self.recording = None;
    }

    /// Whether parity and clip draws that may meet a tie run the rule as their
    /// depth test (`Fragment::TieDepth`, `plan::tie_free`; the default, with
    /// [`Self::set_tie_free`] on), so that they read no texture and wait for
    /// no write of it. Only with D32S8, whose depth image holds the depth as
    /// its float texture does ([`Self::tie_depth`]). Off: they keep the
    /// texture's rule shaders (A/B measurements, `examples/tie_ab.rs`).
    pub fn set_tie_depth(&mut self, on: bool) {
        self.tie_depth = on;
        self.recording = None;
    }

    /// Whether the tie rules of parity and clip draws run as depth tests
    /// ([`Self::set_tie_depth`]): switched on, and D32S8.
    pub(super) fn tie_depth(&self) -> bool {
        self.tie_depth && self.desc.depth_format == DepthFormat::D32S8
    }

    /// Whether a final shade's draw of a mesh that can tie runs the tie rule
    /// only inside its on-screen tie zones (`plan::tie_zones`; the default,
    /// with [`Self::set_fixed_shade`] on). Off: over its whole rectangle (A/B
    /// measurements, `examples/tie_ab.rs`).
    pub fn set_tie_zones(&mut self, on: bool) {
        self.tie_zones = on;
        self.recording = None;
    }

    /// Whether a one-primitive product whose final shade draw would run
    /// depth-`EQUAL` everywhere is shaded in its direct draw, that shade draw
    /// dropped (`plan::direct_shade`; the default). Off: drawn depth-only and
    /// shaded again (A/B measurements, `examples/tie_ab.rs`). Frames run
    /// loop by loop keep the old path; frames shaded into an embedding host's
    /// targets draw those products' final shade draws without a check of the
    /// output depth instead (`record::host`).
    pub fn set_direct_shade(&mut self, on: bool) {
        self.direct_shade = on;
        self.recording = None;
    }

    /// Whether mesh draws are indexed (the default): from each mesh's shared
    /// corners where the program reads no interpolated output (depth-only,
    /// parity, peel and clip passes), from its lit corners where it does
    /// (`corners`'s doc). llvmpipe then shades a corner once per 1,024-index
    /// segment instead of once per triangle that uses it. Off: every draw is
    /// non-indexed from the soup (A/B measurements). Both give identical
    /// images (the same triangles from the same f32 positions; `vk_tests`
    /// `indexed_draws_*`).
    /// Off builds the soup from the uploaded corners, once per upload (it
    /// fails only where that buffer cannot be allocated).
    pub fn set_indexed(&mut self, on: bool) -> Result<(), VkError> {
        self.indexed = on;
        self.recording = None;
        self.ensure_soup()
    }

    /// The soup of the uploaded scene where indexing is off.
    pub(super) fn ensure_soup(&mut self) -> Result<(), VkError> {
        match (&mut self.scene, self.indexed) {
            (Some(scene), false) => {
                let _layer = self.shared.layer_use();
                scene.ensure_soup(&self.shared)
            }
            _ => Ok(()),
        }
    }

    /// Depth images without a stencil aspect for plans that use no stencil
    /// (the default where the device supports `D32_SFLOAT`): half the bytes
    /// to clear and test on lavapipe, the same depths. Off: every plan gets
    /// the set-up's depth-stencil format (the A/B of README "Per-pixel cost").
    pub fn set_depth_only(&mut self, on: bool) {
        self.depth_only = on && self.depth_only_usable;
    }

    /// How clears are recorded (default: clear commands on CPU devices, load ops
    /// elsewhere). Both give the same images.
    pub fn set_clear_mode(&mut self, clears: ClearMode) {
        self.clears = clears;
        self.recording = None;
    }

    /// Which blocks a draw that writes no colour may share (default:
    /// [`BlockJoin::Masked`]; on lavapipe neither wins everywhere, README
    /// "One block for the depth-only draws and the shade"). Both give the
    /// same images.
    pub fn set_block_join(&mut self, join: BlockJoin) {
        self.join = join;
        self.recording = None;
    }

    /// Whether clears reach only the part of an image later steps read (the
    /// default) or the whole image. Both give the same images.
    pub fn set_scissored_clears(&mut self, on: bool) {
        self.scissored_clears = on;
        self.recording = None;
    }

    /// Per-pass GPU times (a timestamp at every `Step::Pass`; the default) or
    /// only the frame's (two timestamps, so that lavapipe's scenes are not cut
    /// at pass boundaries).
    pub fn set_pass_timestamps(&mut self, on: bool) {
        self.pass_timestamps = on;
        self.recording = None;
    }

    /// Where each frame's closing timestamp goes: inside its last block
    /// (`TOP_OF_PIPE`, the default on CPU devices, where it saves lavapipe a
    /// scene per frame) or after all its commands (the default elsewhere).
    /// Both give the same images; `gpu_ms` ends with the last block's draws in
    /// the first.
    pub fn set_frame_timestamps(&mut self, ts: FrameTimestamps) {
        self.frame_ts = ts;
        self.recording = None;
    }

    /// Whether an embedded frame's written final shade draws the insides of
    /// the cavities (subtracted meshes drawn with their front faces culled)
    /// after the solid's faces, tested strictly, where that changes no pixel
    /// (the default), or every piece in the plan's order (A/B).
    pub fn set_insides_last(&mut self, on: bool) {
        self.insides_last = on;
        self.recording = None;
    }

    /// Whether the host's final shade is cut to the openings (the default):
    /// a written piece checks the output depth only where the mesh's front
    /// faces lie inside one of its cutters' boxes
    /// (`plan::cut_away::facing_parts`), and a cavity's inside is drawn only
    /// where it can be seen through them (`CutAway::inside_holes`); or (A/B)
    /// the check covers the whole meeting of the two boxes and the insides
    /// their own rectangles.
    pub fn set_openings(&mut self, on: bool) {
        self.openings = on;
        self.recording = None;
    }

    /// Gives the executor the cutter sets of the uploaded scene under its
    /// current camera and the plan's algorithm (`CutAway::of`): the SCS
    /// subtractions are then cut to where a cavity's inside can be seen
    /// (`plan::Scissor::Openings`). Sets for another camera serve nothing
    /// (each use checks), and a new upload drops them. They must be those of
    /// this scene: a set that misses a cutter would leave `z` unsubtracted
    /// where that cutter opens the solid. [`CutAway::none`] (the default)
    /// keeps every subtraction whole.
    pub fn set_cut_away(&mut self, cut_away: CutAway) {
        self.cut_away = cut_away;
        self.opening_rects.clear();
        self.recording = None;
    }

    /// Drops the kept recording: the next frame records again (what a new plan or
    /// camera costs; the bench measures it with this).
    pub fn forget_recording(&mut self) {
        self.recording = None;
    }
}
