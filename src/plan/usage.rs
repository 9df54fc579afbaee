//! What each step reads and writes: the plan's resources and how a step uses
//! them. The executor derives its barriers, layouts and attachment load ops from
//! this alone (see `vk/sync.rs`), so a new step kind states its hazards here once.

use super::step::{Clear, Draw, Ds, Fragment, Step, Tex};

/// A resource of a plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Resource {
    /// The shaded colour target (shared by the whole plan).
    Color,
    /// The primitive-id target, written with `Color`.
    Prim,
    /// The normal buffer (seed 001 §5.2): written with `Color` when the executor
    /// is asked for normals; plans never name it (the executor adds it wherever
    /// `Color` is written or cleared).
    Normal,
    /// The first layer's edge map (seed 001 §5.1), written by the executor's
    /// edge pass from `Normal` and the output depth; plans never name it.
    Edges,
    /// The transparency accumulation target (seed 000 §6, front to back:
    /// premultiplied colour and coverage), written by the executor's
    /// accumulate pass from `Color` and `Prim`; plans never name it.
    Accum,
    /// The opacity of each primitive id, sampled by the accumulate pass; plans
    /// never name it.
    AlphaTable,
    DepthStencil(Ds),
    Texture(Tex),
}

/// How one step uses one resource.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Usage {
    /// Written (and loaded) as a colour attachment.
    ColorTarget,
    /// Depth- and stencil-tested and written as the depth-stencil attachment.
    DepthStencilTarget,
    /// Read by a fragment shader.
    Sampled,
    /// Whole-image copy source.
    CopySrc,
    /// Whole-image copy destination.
    CopyDst,
    /// Whole-image clear: the previous contents are not needed.
    Clear,
}

impl Usage {
    pub fn writes(self) -> bool {
        !matches!(self, Usage::Sampled | Usage::CopySrc)
    }

    /// Replaces the whole image without reading it.
    pub fn discards(self) -> bool {
        matches!(self, Usage::Clear | Usage::CopyDst)
    }
}

/// Colour targets of a fragment program, in attachment order.
pub fn color_targets(f: &Fragment) -> Vec<Resource> {
    match *f {
        Fragment::None
        | Fragment::DepthFromTexture { .. }
        | Fragment::NearerThan { .. }
        | Fragment::DepthAtDepth { .. } => vec![],
        Fragment::Shade
        | Fragment::Paint { .. }
        | Fragment::Background
        | Fragment::ShadeAtDepth { .. }
        | Fragment::ShadeNearDepth { .. } => vec![Resource::Color, Resource::Prim],
        Fragment::Peel {
            out, shade: true, ..
        } => vec![Resource::Color, Resource::Prim, Resource::Texture(out)],
        Fragment::Peel { out, .. }
        | Fragment::WriteDepth { out }
        | Fragment::PeelTolerant { out, .. }
        | Fragment::CopyTexel { out, .. } => vec![Resource::Texture(out)],
    }
}

/// The texture a fragment program samples, if any.
pub fn sampled_texture(f: &Fragment) -> Option<Tex> {
    match *f {
        Fragment::Peel { prev, .. } | Fragment::PeelTolerant { prev, .. } => Some(prev),
        Fragment::DepthFromTexture { src } | Fragment::CopyTexel { src, .. } => Some(src),
        Fragment::ShadeNearDepth { tex, .. }
        | Fragment::NearerThan { tex, .. }
        | Fragment::ShadeAtDepth { tex }
        | Fragment::DepthAtDepth { tex } => Some(tex),
        Fragment::None
        | Fragment::Shade
        | Fragment::Paint { .. }
        | Fragment::Background
        | Fragment::WriteDepth { .. } => None,
    }
}

fn draw_usage(d: &Draw) -> Vec<(Resource, Usage)> {
    let mut u: Vec<_> = color_targets(&d.fragment)
        .into_iter()
        .map(|r| (r, Usage::ColorTarget))
        .collect();
    u.push((Resource::DepthStencil(d.ds), Usage::DepthStencilTarget));
    if let Some(t) = sampled_texture(&d.fragment) {
        u.push((Resource::Texture(t), Usage::Sampled));
    }
    u
}

impl Step {
    /// The resources this step touches and how. Empty for `Pass` and for `Loop`
    /// (whose body steps declare their own).
    pub fn usage(&self) -> Vec<(Resource, Usage)> {
        match self {
            Step::Pass(_) | Step::Loop(_) => vec![],
            Step::Clear(Clear::DepthStencil { ds, .. }) => {
                vec![(Resource::DepthStencil(*ds), Usage::Clear)]
            }
            Step::Clear(Clear::Texture { tex, .. }) => {
                vec![(Resource::Texture(*tex), Usage::Clear)]
            }
            Step::Clear(Clear::Color) => vec![
                (Resource::Color, Usage::Clear),
                (Resource::Prim, Usage::Clear),
            ],
            Step::CopyTexture { src, dst } => vec![
                (Resource::Texture(*src), Usage::CopySrc),
                (Resource::Texture(*dst), Usage::CopyDst),
            ],
            Step::CopyDepthToTexture { ds, dst } => vec![
                (Resource::Texture(*dst), Usage::ColorTarget),
                (Resource::DepthStencil(*ds), Usage::Sampled),
            ],
            Step::Draw(d) => draw_usage(d),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Geometry;

    fn draw(fragment: Fragment) -> Step {
        Draw::for_test(Geometry::Mesh(0), fragment)
    }

    #[test]
    fn a_peel_samples_prev_and_writes_out_and_depth() {
        let u = draw(Fragment::Peel {
            prev: 0,
            out: 1,
            shade: false,
        })
        .usage();
        assert_eq!(
            u,
            vec![
                (Resource::Texture(1), Usage::ColorTarget),
                (Resource::DepthStencil(0), Usage::DepthStencilTarget),
                (Resource::Texture(0), Usage::Sampled),
            ]
        );
    }

    #[test]
    fn shading_writes_colour_and_id() {
        let u = draw(Fragment::ShadeAtDepth { tex: 2 }).usage();
        assert!(u.contains(&(Resource::Color, Usage::ColorTarget)));
        assert!(u.contains(&(Resource::Prim, Usage::ColorTarget)));
        assert!(u.contains(&(Resource::Texture(2), Usage::Sampled)));
    }

    #[test]
    fn copies_and_clears() {
        let c = Step::CopyTexture { src: 0, dst: 1 }.usage();
        assert_eq!(
            c,
            vec![
                (Resource::Texture(0), Usage::CopySrc),
                (Resource::Texture(1), Usage::CopyDst)
            ]
        );
        assert!(Usage::CopyDst.discards() && Usage::Clear.discards());
        assert!(!Usage::Sampled.writes() && Usage::ColorTarget.writes());
        let d = Step::CopyDepthToTexture { ds: 0, dst: 3 }.usage();
        assert!(d.contains(&(Resource::DepthStencil(0), Usage::Sampled)));
        assert_eq!(Step::Pass("x".into()).usage(), vec![]);
    }
}
