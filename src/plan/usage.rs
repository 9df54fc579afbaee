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
    /// The normal buffer (Kirsch, Nienhaus & Döllner §5.2): written with `Color` when
    /// the executor is asked for normals; plans never name it (the executor adds it
    /// wherever `Color` is written or cleared).
    Normal,
    /// The first layer's edge map (Kirsch, Nienhaus & Döllner §5.1), written by the
    /// executor's edge pass from `Normal` and the output depth; plans never name it.
    Edges,
    /// The transparency accumulation target (Hable & Rossignac §6, front to back:
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
pub fn color_targets(f: &Fragment) -> Uses<Resource> {
    match *f {
        Fragment::None
        | Fragment::DepthFromTexture { .. }
        | Fragment::NearerThan { .. }
        | Fragment::ParityBeforeExit { .. }
        | Fragment::BehindThan { .. }
        | Fragment::MergeBehind { .. }
        | Fragment::TieDepth { .. }
        | Fragment::DepthAtDepth { .. } => Uses::of(&[]),
        Fragment::Shade
        | Fragment::Paint { .. }
        | Fragment::Background
        | Fragment::ShadeAtDepth { .. }
        | Fragment::ShadeNearDepth { .. } => Uses::of(&[Resource::Color, Resource::Prim]),
        Fragment::Peel {
            out, shade: true, ..
        } => Uses::of(&[Resource::Color, Resource::Prim, Resource::Texture(out)]),
        Fragment::Peel { out, .. }
        | Fragment::WriteDepth { out }
        | Fragment::PeelTolerant { out, .. }
        | Fragment::CopyTexel { out, .. } => Uses::of(&[Resource::Texture(out)]),
    }
}

/// The texture a fragment program samples, if any.
pub fn sampled_texture(f: &Fragment) -> Option<Tex> {
    match *f {
        Fragment::Peel { prev, .. } | Fragment::PeelTolerant { prev, .. } => Some(prev),
        Fragment::DepthFromTexture { src } | Fragment::CopyTexel { src, .. } => Some(src),
        Fragment::ShadeNearDepth { tex, .. }
        | Fragment::NearerThan { tex, .. }
        | Fragment::ParityBeforeExit { tex, .. }
        | Fragment::BehindThan { tex, .. }
        | Fragment::MergeBehind { tex, .. }
        | Fragment::ShadeAtDepth { tex }
        | Fragment::DepthAtDepth { tex } => Some(tex),
        Fragment::None
        | Fragment::Shade
        | Fragment::Paint { .. }
        | Fragment::Background
        | Fragment::TieDepth { .. }
        | Fragment::WriteDepth { .. } => None,
    }
}

impl Draw {
    /// The resources this draw touches and how ([`Step::usage`] of a draw).
    pub fn usage(&self) -> Uses<(Resource, Usage)> {
        draw_usage(self)
    }
}

/// `uses` with the normal buffer as a colour target after the colour target,
/// when the normal buffer is on (the executor's programs write it there
/// wherever they write colour, Kirsch, Nienhaus & Döllner §5.2).
pub fn with_normals(mut uses: Uses<(Resource, Usage)>, normals: bool) -> Uses<(Resource, Usage)> {
    if normals && uses.contains(&(Resource::Color, Usage::ColorTarget)) {
        uses.push((Resource::Normal, Usage::ColorTarget));
    }
    uses
}

fn draw_usage(d: &Draw) -> Uses<(Resource, Usage)> {
    let mut u = Uses::default();
    for r in color_targets(&d.fragment) {
        u.push((r, Usage::ColorTarget));
    }
    u.push((Resource::DepthStencil(d.ds), Usage::DepthStencilTarget));
    if let Some(t) = sampled_texture(&d.fragment) {
        u.push((Resource::Texture(t), Usage::Sampled));
    }
    u
}

impl Step {
    /// The resources this step touches and how. Empty for `Pass` and for `Loop`
    /// (whose body steps declare their own).
    pub fn usage(&self) -> Uses<(Resource, Usage)> {
        match self {
            Step::Pass(_) | Step::Loop(_) => Uses::default(),
            Step::Clear(Clear::DepthStencil { ds, .. }) => {
                Uses::of(&[(Resource::DepthStencil(*ds), Usage::Clear)])
            }
            Step::Clear(Clear::Texture { tex, .. }) => {
                Uses::of(&[(Resource::Texture(*tex), Usage::Clear)])
            }
            Step::Clear(Clear::Color) => Uses::of(&[
                (Resource::Color, Usage::Clear),
                (Resource::Prim, Usage::Clear),
            ]),
            Step::CopyTexture { src, dst } => Uses::of(&[
                (Resource::Texture(*src), Usage::CopySrc),
                (Resource::Texture(*dst), Usage::CopyDst),
            ]),
            Step::CopyDepthBound { src, dst } => Uses::of(&[
                (Resource::DepthStencil(*src), Usage::CopySrc),
                (Resource::DepthStencil(*dst), Usage::CopyDst),
            ]),
            Step::CopyDepthToTexture { ds, dst } => Uses::of(&[
                (Resource::Texture(*dst), Usage::ColorTarget),
                (Resource::DepthStencil(*ds), Usage::Sampled),
            ]),
            Step::Draw(d) => draw_usage(d),
        }
    }
}

/// Most entries of a [`Uses`]: a shading peel's three colour targets, its
/// depth-stencil and sampled texture, and the normal buffer the executor adds.
pub const MAX_USES: usize = 6;

/// A step's few resources (or usages), inline: asked for per step whenever a
/// frame is recorded, so they allocate nothing (re-recording at
/// ≤ 1 µs per draw). Reads as a slice.
#[derive(Clone, Copy, Debug)]
pub struct Uses<T: Slot> {
    items: [T; MAX_USES],
    len: u8,
}

/// What a [`Uses`] holds; `FILL` stands in its unused slots (never read).
pub trait Slot: Copy {
    const FILL: Self;
}

impl Slot for Resource {
    const FILL: Self = Resource::Color;
}

impl Slot for (Resource, Usage) {
    const FILL: Self = (Resource::Color, Usage::Sampled);
}

impl<T: Slot> Default for Uses<T> {
    fn default() -> Self {
        Uses {
            items: [T::FILL; MAX_USES],
            len: 0,
        }
    }
}

impl<T: Slot> Uses<T> {
    pub fn of(items: &[T]) -> Uses<T> {
        let mut u = Uses::default();
        for &i in items {
            u.push(i);
        }
        u
    }

    pub fn push(&mut self, item: T) {
        assert!(
            (self.len as usize) < MAX_USES,
            "a step uses at most {MAX_USES} resources"
        );
        self.items[self.len as usize] = item;
        self.len += 1;
    }
}

impl<T: Slot> std::ops::Deref for Uses<T> {
    type Target = [T];

    fn deref(&self) -> &[T] {
        &self.items[..self.len as usize]
    }
}

impl<T: Slot> IntoIterator for Uses<T> {
    type Item = T;
    type IntoIter = std::iter::Take<std::array::IntoIter<T, MAX_USES>>;

    fn into_iter(self) -> Self::IntoIter {
        self.items.into_iter().take(self.len as usize)
    }
}

impl<T: Slot + PartialEq> PartialEq for Uses<T> {
    fn eq(&self, o: &Self) -> bool {
        **self == **o
    }
}

impl<T: Slot + PartialEq> PartialEq<Vec<T>> for Uses<T> {
    fn eq(&self, o: &Vec<T>) -> bool {
        **self == **o
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
        assert!(Step::Pass("x".into()).usage().is_empty());
    }
}
