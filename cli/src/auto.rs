//! `--algo auto`: per scene, the algorithm expected to be fastest among those
//! that render it correctly.
//!
//! The plan is the cost model ([`crate::bench::estimate`]): each candidate's
//! plan is built and its frame estimated from its counts (draws, triangles,
//! pixels of mesh draws, pixels of full-screen passes and copies, each peel loop
//! taken once per layer the scene has along a coarse grid of rays), weighed by
//! [`AUTO_MODEL`], whose weights were fitted to a bench run of every shipped
//! scene on lavapipe. The cheapest estimate wins.
//!
//! Candidates are the speckle-free algorithms: CST-I, CST-Z, CST-G, Blister,
//! Goldfeather and layered Goldfeather. Left out: Trickle (its depth tolerance
//! loses features thinner than it), the paper's Blister parity (speckles on
//! coincident faces, kept for measuring them), Kirsch (its opaque image is only
//! its first layer's product peel) and SCS (Stewart, Leach & John's sequenced
//! subtraction: single interior pixels come out wrong where CST-I has none, e.g.
//! the gear and a flush OpenSCAD pocket's floor). A scene with surfaces or one
//! drawn in layers (transparency, styles, `%` parts) is drawn by the CST
//! variants only.

use std::collections::BTreeMap;

use serde::Serialize;

use peeltrim::plan::{self, Algo, BuildOptions, Prepared};
use peeltrim::scene::Scene;

use crate::bench::estimate::{CostModel, SceneCosts};

/// The candidates, in the order ties are broken.
pub const CANDIDATES: [Algo; 6] = [
    Algo::CstI,
    Algo::CstZ,
    Algo::CstG,
    Algo::Blister,
    Algo::Goldfeather,
    Algo::GoldfeatherLayered,
];

/// Whether `auto` may pick `algo` (correct on every scene it accepts, no
/// speckles).
pub fn speckle_free(algo: Algo) -> bool {
    CANDIDATES.contains(&algo)
}

/// The per-item costs `auto` weighs plan counts with: non-negative least
/// squares on relative error of the frame time (`frame_ms_median`) over the
/// candidates' runs in a bench of every shipped scene (200×200, 3 frames,
/// lavapipe on 2 loaded cores; docs/perf/2026-12-07-auto.md). The fit gave no
/// weight to full-screen pixels (their cost hides in the per-draw weight) and
/// 0.26 ms a frame, which no ranking needs.
pub const AUTO_MODEL: CostModel = CostModel {
    per_draw_s: 15.7e-6,
    per_triangle_s: 0.122e-6,
    per_mesh_pixel_s: 2.62e-9,
    per_sweep_pixel_s: 0.0,
};

/// What `auto` chose for a scene, and why (`stats.json`'s `auto`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct AutoPick {
    /// The algorithm picked.
    pub picked: String,
    /// One sentence: why it was picked.
    pub reason: String,
    /// Each candidate's estimated frame time (ms) on the model above.
    pub estimates: BTreeMap<String, f64>,
    /// Candidates that could not render the scene, with why.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub excluded: BTreeMap<String, String>,
    #[serde(skip)]
    pub algo: Option<Algo>,
}

impl AutoPick {
    /// The algorithm picked.
    pub fn algo(&self) -> Algo {
        self.algo.unwrap_or(Algo::CstI)
    }
}

/// Picks the algorithm for `scene` at `width`×`height`; `layered`: the frame
/// is drawn in layers (only the CST variants draw those).
pub fn pick(
    scene: &Scene,
    prep: &Prepared,
    width: u32,
    height: u32,
    layered: bool,
    build: &BuildOptions,
) -> AutoPick {
    let costs = SceneCosts::new(scene, prep, width, height);
    let mut p = AutoPick::default();
    let mut best: Option<(Algo, f64)> = None;
    let surfaces = !prep.surfaces.is_empty();
    for algo in CANDIDATES {
        let cst = matches!(algo, Algo::CstZ | Algo::CstI | Algo::CstG);
        if !cst && layered {
            p.excluded
                .insert(algo.name().into(), "draws no layers".into());
            continue;
        }
        if !cst && surfaces {
            p.excluded
                .insert(algo.name().into(), "draws no surfaces".into());
            continue;
        }
        let plan = match plan::build_with(algo, prep, build) {
            Ok(plan) => plan,
            Err(e) => {
                p.excluded.insert(algo.name().into(), e.to_string());
                continue;
            }
        };
        let ms = costs.estimate(&plan, prep, &AUTO_MODEL).seconds * 1e3;
        p.estimates
            .insert(algo.name().into(), (ms * 1e3).round() / 1e3);
        if best.map_or(true, |(_, b)| ms < b) {
            best = Some((algo, ms));
        }
    }
    let (algo, ms) = best.unwrap_or((Algo::CstI, f64::NAN));
    p.algo = Some(algo);
    p.picked = algo.name().into();
    let runner_up = p
        .estimates
        .iter()
        .filter(|(n, _)| n.as_str() != algo.name())
        .min_by(|a, b| a.1.total_cmp(b.1));
    let among = if layered {
        "the CST variants (the frame is drawn in layers)"
    } else if surfaces {
        "the CST variants (the scene has surfaces)"
    } else {
        "the speckle-free algorithms"
    };
    p.reason = match runner_up {
        Some((r, rms)) if (rms - ms).abs() < 1e-3 => format!(
            "lowest estimated frame time among {among}: {ms:.1} ms, as for {r} (the same \
             work; a tie goes to the earlier of cst-i, cst-z, cst-g, blister, goldfeather, \
             goldfeather-layered), estimated from the plan's draws, triangles and pixels"
        ),
        Some((r, rms)) => format!(
            "lowest estimated frame time among {among}: {ms:.1} ms against {rms:.1} ms for {r}, \
             estimated from the plan's draws, triangles and pixels"
        ),
        None if ms.is_finite() => format!("the only one of {among} that can render the scene"),
        None => "no candidate could plan the scene; cst-i reports why".into(),
    };
    p
}
