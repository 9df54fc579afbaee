//! The executor's settings (`set_*`) that choose what a frame measures or
//! cuts away — per-pass timestamps, the cutter sets — and the push-constant
//! flags the device profile implies. Each drops the kept recording where it
//! changes what is recorded. How a plan is recorded on a device (clears,
//! frame timestamps, depth-equal shades, vertex snapping) is the
//! [`crate::vk::DeviceProfile`]'s.

use super::{DepthFormat, Executor};
use crate::plan::cut_away::CutAway;
use crate::vk::pipeline::{pipeline_flags, FLAG_RASTER_DEPTH};

impl Executor {
    /// The push constants' flags: reversed Z, and the subpixel precision the tie
    /// tolerance assumes ([`Self::subpixel_bits`]).
    pub(super) fn flags(&self) -> u32 {
        let raster = match self.depth_equal_shades() {
            true => FLAG_RASTER_DEPTH,
            false => 0,
        };
        pipeline_flags(self.desc.reversed_z, self.subpixel_bits()) | raster
    }

    /// Whether the final shade's draws of meshes that cannot tie run as plain
    /// depth-`EQUAL` draws (`plan::tie_free`): only where the profile's raster
    /// depth is as exact as the tie rule's plane depth
    /// ([`crate::vk::DeviceProfile::depth_equal_shades`]). Elsewhere a
    /// depth-equal shade would leave the raster depth, with its snapping
    /// error, in the depth output, and they keep the tie rule.
    pub(super) fn depth_equal_shades(&self) -> bool {
        self.profile.depth_equal_shades(self.desc.depth_format)
    }

    /// The vertex snapping the tie rule allows for: the profile's (the
    /// device's, or the emulated device's).
    pub(super) fn subpixel_bits(&self) -> u32 {
        self.profile.subpixel_bits
    }

    /// Whether parity and clip draws that may meet a tie run the rule as their
    /// depth test (`Fragment::TieDepth`, `plan::tie_free`), so that they read
    /// no texture and wait for no write of it: only with D32S8, whose depth
    /// image holds the depth as its float texture does.
    pub(super) fn tie_depth(&self) -> bool {
        self.desc.depth_format == DepthFormat::D32S8
    }

    /// Per-pass GPU times (a timestamp at every `Step::Pass`; the default) or
    /// only the frame's (two timestamps, so that lavapipe's scenes are not cut
    /// at pass boundaries).
    pub fn set_pass_timestamps(&mut self, on: bool) {
        self.pass_timestamps = on;
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
