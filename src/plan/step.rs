//! The step vocabulary shared by all plan builders and the Vulkan executor.
//!
//! Depth semantics are written for the standard convention: smaller depth is
//! nearer, `0.0` is the near plane and `1.0` the far plane. With reversed Z the
//! executor mirrors every compare op, clear value and constant depth, and the
//! shaders flip their own comparisons, so plans never mention the convention.

/// Index of a depth-stencil image of the plan (`0 .. Plan::depth_stencils`).
pub type Ds = u8;
/// Index of a single-channel `f32` depth texture of the plan (`0 .. Plan::textures`):
/// colour targets that hold copies of depths and are sampled by later passes.
pub type Tex = u8;
/// Index of a mesh: primitives in file order (0-based), then surfaces.
pub type MeshId = u32;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CompareOp {
    Never,
    Less,
    Equal,
    LessOrEqual,
    Greater,
    NotEqual,
    GreaterOrEqual,
    Always,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StencilOp {
    Keep,
    Zero,
    Replace,
    IncrementAndClamp,
    DecrementAndClamp,
    Invert,
    IncrementAndWrap,
    DecrementAndWrap,
}

/// Which faces are discarded before rasterization. Front faces are the
/// counter-clockwise ones seen from the eye, i.e. outward-facing ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Cull {
    None,
    Back,
    Front,
}

/// Stencil ops and compare for one face orientation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StencilFace {
    pub compare: CompareOp,
    pub fail: StencilOp,
    pub pass: StencilOp,
    pub depth_fail: StencilOp,
}

/// The full stencil state of a draw. Masks and reference apply to both faces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StencilState {
    pub front: StencilFace,
    pub back: StencilFace,
    pub compare_mask: u8,
    pub write_mask: u8,
    pub reference: u8,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DepthState {
    pub compare: CompareOp,
    pub write: bool,
}

/// What a draw rasterizes.
#[derive(Clone, Debug, PartialEq)]
pub enum Geometry {
    /// All triangles of one mesh.
    Mesh(MeshId),
    /// Several meshes, in this order (e.g. the union of all faces for a Blister peel).
    Meshes(Vec<MeshId>),
    /// A rectangle covering the (scissored) screen at constant normalized depth
    /// (`0.0` near, `1.0` far).
    FullScreen { depth: f32 },
    /// The pixels the faces of mesh `mesh` that the draw's cull keeps cover,
    /// at constant normalized depth `depth`: a full-screen pass cut to the
    /// mesh's footprint. The executor collapses the viewport's depth range to
    /// `depth`, so the mesh is clipped, and covers the pixels, exactly as its
    /// own draws with the same cull and scissor (`gl_Position` is invariant).
    /// SCS's reject sweep of a product drawn in the output (`plan::scs`).
    Footprint { mesh: MeshId, depth: f32 },
}

impl Geometry {
    /// The meshes whose triangles the draw rasterizes (none for the quad).
    pub fn meshes(&self) -> &[MeshId] {
        match self {
            Geometry::Mesh(m) | Geometry::Footprint { mesh: m, .. } => std::slice::from_ref(m),
            Geometry::Meshes(ms) => ms,
            Geometry::FullScreen { .. } => &[],
        }
    }
}

/// Where a draw may touch pixels. The executor turns mesh bounds into the
/// screen rectangle of their projected bounding boxes (the full screen when a box
/// crosses the near plane), so full-screen passes only sweep what they can change.
#[derive(Clone, Debug, PartialEq)]
pub enum Scissor {
    Full,
    BoundsOf(Vec<MeshId>),
    /// The rectangle of `meshes` cut to the rectangle of all of `within` (one
    /// union, where [`Scissor::Overlap`] cuts to each mesh of `and`): a draw whose effect is
    /// read only where `within`'s faces can be (Goldfeather's parity draws of a
    /// large primitive clipping a small literal's surface).
    Within {
        meshes: Vec<MeshId>,
        within: Vec<MeshId>,
    },
    /// The rectangle of `BoundsOf(of)` clipped to the rectangle of each mesh of
    /// `and`: a step that can only change pixels where all of them may be, e.g.
    /// a CST parity draw of a trimming primitive, which matters only where the
    /// peeled leaf has candidates (Hable & Rossignac §4). Empty when they do not
    /// meet.
    Overlap {
        of: Vec<MeshId>,
        and: Vec<MeshId>,
    },
    /// The rectangle of the meshes `first..end`, a run of consecutive ids: what
    /// `BoundsOf` of them is, in O(1) space. Blister sweeps every solid once per
    /// Blist entry; a list of all n meshes on each of n sweeps made its plan
    /// quadratic (15 GB for 10⁵ nested differences).
    Run {
        first: MeshId,
        end: MeshId,
    },
    /// [`Scissor::Overlap`] of `[of]` and `and`, cut to where the inside of
    /// `of` can be seen through an opening (`plan::cut_away::CutAway::inside_holes`)
    /// where the executor has been given the cutter sets: an SCS subtraction
    /// of cutter `of` moves `z` only where `z` lies inside it, and a `z` on
    /// the product's front face or on another cutter's exit lies inside `of`
    /// only there (docs/embedding.md).
    Openings {
        of: MeshId,
        and: Vec<MeshId>,
    },
}

impl Scissor {
    /// The bounds of `meshes`: a [`Scissor::Run`] when they are consecutive ids
    /// in ascending order (as a scene's solid primitives usually are), else
    /// [`Scissor::BoundsOf`] them.
    pub fn bounds_of_all(meshes: &[MeshId]) -> Scissor {
        let consecutive = meshes.windows(2).all(|w| w[1] == w[0] + 1);
        match (meshes.first(), meshes.last(), consecutive) {
            (Some(&first), Some(&last), true) => Scissor::Run {
                first,
                end: last + 1,
            },
            _ => Scissor::BoundsOf(meshes.to_vec()),
        }
    }

    /// The meshes whose bounds the scissor is made from.
    pub fn meshes(&self) -> impl Iterator<Item = MeshId> + '_ {
        let (a, b): (&[MeshId], &[MeshId]) = match self {
            Scissor::Full | Scissor::Run { .. } => (&[], &[]),
            Scissor::BoundsOf(ms) => (ms, &[]),
            Scissor::Overlap { of, and } => (of, and),
            Scissor::Within { meshes, within } => (meshes, within),
            Scissor::Openings { of, and } => (std::slice::from_ref(of), and),
        };
        let run = match *self {
            Scissor::Run { first, end } => first..end,
            _ => 0..0,
        };
        a.iter().chain(b).copied().chain(run)
    }
}

/// The fragment program of a draw and the colour targets it writes. Every variant
/// that writes `color` writes the primitive index (mesh index + 1) to the
/// primitive-id target too; both targets are shared by the whole plan.
#[derive(Clone, Debug, PartialEq)]
pub enum Fragment {
    /// Depth and stencil only; no colour target is bound.
    None,
    /// Shaded colour (flat, headlight, two-sided) and primitive id of the mesh.
    Shade,
    /// Paint colour (given as RGB) and the mesh's primitive id: CST painting.
    Paint { rgb: [u8; 3] },
    /// Background colour and primitive id 0 (resets of rejected pixels).
    Background,
    /// Depth peeling: discard fragments not strictly behind texture `prev` at this
    /// pixel; write the fragment's depth into texture `out`. With `shade`, also
    /// write colour and primitive id.
    Peel { prev: Tex, out: Tex, shade: bool },
    /// Write the fragment's depth into texture `out` (and nothing else).
    WriteDepth { out: Tex },
    /// Keep only fragments at or in front of texture `tex` plus `eps` (normalized
    /// depth); no colour output. Parity counting that treats faces coincident with
    /// the candidate (within `eps`) as in front of it, so the point classified is
    /// the one just behind all of them — regularized, whatever the rounding.
    /// `eps` is signed: a negative one keeps only fragments more than `-eps` in
    /// front of `tex` (CST's `Less` tie rule, Hable & Rossignac §5).
    ///
    /// Every plan draws it with the depth test off into a depth-stencil image
    /// that holds `tex`'s depth wherever the draw's result is read, so where no
    /// face can tie ([`super::tie_free`]) the executor runs it as a plain
    /// `LessOrEqual` (`Less` for a negative `eps`) depth test instead.
    NearerThan { tex: Tex, eps: f32 },
    /// [`Fragment::NearerThan`] in the parity draw (every face, bit inverted)
    /// of a convex mesh the rays start outside of, whose bit only its exit
    /// reads: a draw of its back faces tested depth `Greater` that clears the
    /// bit whether or not the test passes. That test already rejects a back
    /// face at or in front of the candidate, so where the mesh is tie-free the
    /// executor draws only its front faces, tested `LessOrEqual` with no
    /// fragment shader (OpenCSG's SCS subtraction: front faces, then back
    /// faces); elsewhere it is `NearerThan` (`plan::scs`).
    ParityBeforeExit { tex: Tex, eps: f32 },
    /// The tie rule's compare of SCS's [`Fragment::ParityBeforeExit`] or
    /// [`Fragment::BehindThan`] moved into the depth test: the fragment depth,
    /// moved nearer by the tolerance `eps` (signed, as theirs) and the slope
    /// term in its direction (`shaders/tie_depth.frag`), is tested
    /// `LessOrEqual` (nearer) or `Greater` (behind) against the depth-stencil
    /// image, which holds the texture's depth wherever the result is read
    /// (their invariant). No texture is read, so nothing waits for the
    /// texture's writes. Never planned: the executor's lowering of a draw
    /// that may meet a tie, where the image holds that depth exactly (D32)
    /// and the draw's meshes tie only with parallel faces ([`super::tie_free`]).
    TieDepth { eps: f32 },
    /// Shade and write the primitive id only where the fragment's depth is within
    /// `eps` (normalized depth) of texture `tex` at this pixel: depth-equal shading
    /// with a documented tolerance, so coincident faces of several primitives all
    /// qualify and the draw order decides which id stays (the last drawn wins).
    /// `equal_cull`: the faces of the draw's mesh that are never the visible
    /// surface ([`super::VisibleSides`]), which its depth-equal form (a mesh
    /// that cannot tie, `plan::tie_free`) culls; the draw itself culls nothing,
    /// since a culled face may still be the lowest index coincident with the
    /// visible one.
    ShadeNearDepth {
        tex: Tex,
        eps: f32,
        equal_cull: Cull,
    },
    /// Keep only fragments behind texture `tex` by more than `eps`: the
    /// complement of [`Fragment::NearerThan`]'s test (ties decided alike); no
    /// colour output. SCS's clip by back faces (`plan::scs`): where `z` is at or
    /// behind a convex positive primitive's front face, it is inside the
    /// primitive exactly where its back face passes, and a stencil count of the
    /// passes over all positive primitives says whether `z` is in all of them.
    ///
    /// Drawn, as `NearerThan`, with the depth test off into a depth-stencil
    /// image holding `tex`'s depth wherever its result is read, so where no face
    /// can tie ([`super::tie_free`]) the executor runs it as a plain `Greater`
    /// (`GreaterOrEqual` for a negative `eps`) depth test.
    BehindThan { tex: Tex, eps: f32 },
    /// The depth of texture `tex` as the fragment depth, only where this
    /// fragment is behind it by more than the tolerance `eps` (the opposite of
    /// [`Fragment::NearerThan`]'s test, ties decided alike) and `tex` is not
    /// far; no colour output. SCS's clip and merge of a product with one
    /// positive primitive in one draw of its back faces (`plan::scs`). With
    /// `eps` 0 the test is exact and the program fetches one texel (the
    /// executor's rewrite where no face can tie, [`super::tie_free`]).
    MergeBehind { tex: Tex, eps: f32 },
    /// Full-screen copy of texture `src` into the fragment depth (`gl_FragDepth`),
    /// discarding pixels where `src` holds the far value 1.0 (nothing there).
    DepthFromTexture { src: Tex },
    /// Tolerant depth peeling: discard fragments not behind texture `prev` by more
    /// than `eps` (normalized depth; kept: `z - eps > prev`); write the fragment's
    /// depth into texture `out`. Depth-stencil ops apply to the kept fragments only.
    PeelTolerant { prev: Tex, out: Tex, eps: f32 },
    /// Full-screen copy of texture `src` into texture `out` at the pixels the draw's
    /// stencil (and depth) tests pass; the fragment depth is the rectangle's.
    CopyTexel { src: Tex, out: Tex },
    /// Shaded colour and primitive id, only where the fragment depth equals texture
    /// `tex` at this pixel bit-exactly (other fragments are discarded before the
    /// depth test writes anything). Exact because `gl_Position` is invariant: a mesh
    /// redrawn with the same transform reproduces the depths a `Peel` recorded. CST
    /// merges a trimmed surface into the final image with it (Hable & Rossignac §4,
    /// Render(S)).
    ShadeAtDepth { tex: Tex },
    /// [`Fragment::ShadeAtDepth`] without colour targets: the depth only, where
    /// the fragment depth equals texture `tex` bit-exactly. A solid's CST merge,
    /// whose colour and id the final depth-equal shading
    /// ([`Fragment::ShadeNearDepth`]) overwrites at every pixel it wins.
    DepthAtDepth { tex: Tex },
}

/// One rasterization.
#[derive(Clone, Debug, PartialEq)]
pub struct Draw {
    pub geometry: Geometry,
    pub scissor: Scissor,
    pub cull: Cull,
    /// The depth-stencil image tested and written.
    pub ds: Ds,
    pub depth: DepthState,
    /// `None`: stencil test disabled.
    pub stencil: Option<StencilState>,
    pub fragment: Fragment,
    /// Count samples passing this draw with an occlusion query; a [`Loop`] stops
    /// when the counted draws of its `head` pass no sample.
    pub count_samples: bool,
}

#[cfg(test)]
impl Draw {
    /// A plain draw for unit tests: depth-tested into depth-stencil 0, no stencil,
    /// no sample counting.
    pub(crate) fn for_test(geometry: Geometry, fragment: Fragment) -> Step {
        Step::Draw(Draw {
            geometry,
            scissor: Scissor::Full,
            cull: Cull::None,
            ds: 0,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: None,
            fragment,
            count_samples: false,
        })
    }
}

/// Whole-image clears.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Clear {
    /// Depth (`0.0` near, `1.0` far) and stencil of one depth-stencil image.
    DepthStencil { ds: Ds, depth: f32, stencil: u8 },
    /// A depth texture to a normalized depth value.
    Texture { tex: Tex, depth: f32 },
    /// Colour to the background, primitive id to 0.
    Color,
}

/// A data-dependent repeat: run `head`; stop when its `count_samples` draws passed
/// no sample (or after `max_iterations`); otherwise run `tail` and repeat.
#[derive(Clone, Debug, PartialEq)]
pub struct Loop {
    pub head: Vec<Step>,
    pub tail: Vec<Step>,
    pub max_iterations: u32,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Starts a named pass group: a timestamp boundary in `stats.json` and a
    /// heading in the plan printout. Groups with the same name are summed.
    Pass(String),
    Clear(Clear),
    Draw(Draw),
    /// Copy one depth texture into another (same size and format).
    CopyTexture {
        src: Tex,
        dst: Tex,
    },
    /// Copy the depth of a depth-stencil image into a depth texture.
    CopyDepthToTexture {
        ds: Ds,
        dst: Tex,
    },
    Loop(Loop),
}

/// An algorithm's complete work for one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// The algorithm's name as on the command line (`blister`, `cst-i`, ...).
    pub algo: String,
    /// Number of depth-stencil images used (at least 1).
    pub depth_stencils: u8,
    /// Number of depth textures used.
    pub textures: u8,
    /// Stencil bits the plan relies on (for reporting; all formats have 8).
    pub stencil_bits: u8,
    /// The depth-stencil image whose depth is the visible surface at the end.
    pub output_ds: Ds,
    pub steps: Vec<Step>,
}

impl Plan {
    /// The plan's top-level peel loops, in plan order.
    pub fn loops(&self) -> impl Iterator<Item = &Loop> {
        self.steps.iter().filter_map(|s| match s {
            Step::Loop(l) => Some(l),
            _ => None,
        })
    }
}
