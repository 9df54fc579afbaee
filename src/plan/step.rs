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

/// A depth or stencil compare (Vulkan's `VkCompareOp`): the test passes when the
/// fragment's depth (or the stencil reference) compares so with the stored value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CompareOp {
    /// Never passes.
    Never,
    /// Passes when the new value is less: for depth, strictly nearer.
    Less,
    /// Passes when the values are equal (bit-exact for depth).
    Equal,
    /// Passes when the new value is less or equal: for depth, nearer or tied.
    LessOrEqual,
    /// Passes when the new value is greater: for depth, strictly farther.
    Greater,
    /// Passes when the values differ.
    NotEqual,
    /// Passes when the new value is greater or equal: for depth, farther or tied.
    GreaterOrEqual,
    /// Always passes (test disabled).
    Always,
}

/// What a stencil test outcome does to the stored value (Vulkan's `VkStencilOp`);
/// only the bits of [`StencilState::write_mask`] change.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StencilOp {
    /// Leaves the value.
    Keep,
    /// Sets it to 0 (clears labels or a parity bit).
    Zero,
    /// Writes [`StencilState::reference`] (sets a Blist label or a flag).
    Replace,
    /// Adds 1, saturating at 255 (counts layers or products).
    IncrementAndClamp,
    /// Subtracts 1, stopping at 0.
    DecrementAndClamp,
    /// Flips the bits: with a one-bit write mask, toggles a parity bit (an odd count
    /// of faces in front of the candidate means inside, Goldfeather's and Blister's parity).
    Invert,
    /// Adds 1 modulo 256.
    IncrementAndWrap,
    /// Subtracts 1 modulo 256.
    DecrementAndWrap,
}

/// Which faces are discarded before rasterization. Front faces are the
/// counter-clockwise ones seen from the eye, i.e. outward-facing ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Cull {
    /// Rasterizes both orientations (parity draws count every face).
    None,
    /// Discards back faces: only the front faces, where rays enter the solid.
    Back,
    /// Discards front faces: only the back faces, where rays leave the solid.
    Front,
}

/// Stencil ops and compare for one face orientation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StencilFace {
    /// The stencil test: `reference & compare_mask` against the stored value `& compare_mask`.
    pub compare: CompareOp,
    /// Applied where the stencil test fails.
    pub fail: StencilOp,
    /// Applied where the stencil and the depth test pass.
    pub pass: StencilOp,
    /// Applied where the stencil test passes and the depth test fails.
    pub depth_fail: StencilOp,
}

/// The full stencil state of a draw. Masks and reference apply to both faces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StencilState {
    /// Ops and compare for front faces.
    pub front: StencilFace,
    /// Ops and compare for back faces.
    pub back: StencilFace,
    /// The stencil bits the compare reads (a Blist label, a parity bit, a counter).
    pub compare_mask: u8,
    /// The stencil bits the ops may change.
    pub write_mask: u8,
    /// The value compared against and written by [`StencilOp::Replace`].
    pub reference: u8,
}

/// The depth test and depth write of a draw against its depth-stencil image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DepthState {
    /// The compare of the fragment depth against the stored depth (standard Z).
    pub compare: CompareOp,
    /// Whether fragments that pass the depth test write their depth.
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
    FullScreen {
        /// The rectangle's normalized depth.
        depth: f32,
    },
    /// The pixels the faces of mesh `mesh` that the draw's cull keeps cover,
    /// at constant normalized depth `depth`: a full-screen pass cut to the
    /// mesh's footprint. The executor collapses the viewport's depth range to
    /// `depth`, so the mesh is clipped, and covers the pixels, exactly as its
    /// own draws with the same cull and scissor (`gl_Position` is invariant).
    /// SCS's reject sweep of a product drawn in the output (`plan::scs`).
    Footprint {
        /// The mesh whose footprint the pass covers.
        mesh: MeshId,
        /// The normalized depth of every covered pixel.
        depth: f32,
    },
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
    /// The whole image.
    Full,
    /// The rectangle of these meshes' bounds.
    BoundsOf(Vec<MeshId>),
    /// The rectangle of `meshes` cut to the rectangle of all of `within` (one
    /// union, where [`Scissor::Overlap`] cuts to each mesh of `and`): a draw whose effect is
    /// read only where `within`'s faces can be (Goldfeather's parity draws of a
    /// large primitive clipping a small literal's surface).
    Within {
        /// The meshes whose bounds the draw may touch.
        meshes: Vec<MeshId>,
        /// The meshes whose one union of bounds cuts that rectangle.
        within: Vec<MeshId>,
    },
    /// The rectangle of `BoundsOf(of)` clipped to the rectangle of each mesh of
    /// `and`: a step that can only change pixels where all of them may be, e.g.
    /// a CST parity draw of a trimming primitive, which matters only where the
    /// peeled leaf has candidates (Hable & Rossignac §4). Empty when they do not
    /// meet.
    Overlap {
        /// The meshes whose bounds make the rectangle.
        of: Vec<MeshId>,
        /// The meshes each of whose rectangles cuts it.
        and: Vec<MeshId>,
    },
    /// The rectangle of the meshes `first..end`, a run of consecutive ids: what
    /// `BoundsOf` of them is, in O(1) space. Blister sweeps every solid once per
    /// Blist entry; a list of all n meshes on each of n sweeps made its plan
    /// quadratic (15 GB for 10⁵ nested differences).
    Run {
        /// The first mesh of the run.
        first: MeshId,
        /// One past the last mesh of the run.
        end: MeshId,
    },
    /// [`Scissor::Overlap`] of `[of]` and `and`, cut to where the inside of
    /// `of` can be seen through an opening (`plan::cut_away::CutAway::inside_holes`)
    /// where the executor has been given the cutter sets: an SCS subtraction
    /// of cutter `of` moves `z` only where `z` lies inside it, and a `z` on
    /// the product's front face or on another cutter's exit lies inside `of`
    /// only there (docs/embedding.md).
    Openings {
        /// The cutter the SCS subtraction draws.
        of: MeshId,
        /// The meshes each of whose rectangles cuts it, as in [`Scissor::Overlap`].
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
    Paint {
        /// The paint colour (the surface's `paint_color`).
        rgb: [u8; 3],
    },
    /// Background colour and primitive id 0 (resets of rejected pixels).
    Background,
    /// Depth peeling: discard fragments not strictly behind texture `prev` at this
    /// pixel; write the fragment's depth into texture `out`. With `shade`, also
    /// write colour and primitive id.
    Peel {
        /// The texture holding the previous layer's depth.
        prev: Tex,
        /// The texture receiving this layer's depth.
        out: Tex,
        /// Also write shaded colour and primitive id.
        shade: bool,
    },
    /// Write the fragment's depth into texture `out` (and nothing else).
    WriteDepth {
        /// The texture receiving the fragment depth.
        out: Tex,
    },
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
    NearerThan {
        /// The texture holding the candidate's depth.
        tex: Tex,
        /// The signed tie tolerance (normalized depth).
        eps: f32,
    },
    /// [`Fragment::NearerThan`] in the parity draw (every face, bit inverted)
    /// of a convex mesh the rays start outside of, whose bit only its exit
    /// reads: a draw of its back faces tested depth `Greater` that clears the
    /// bit whether or not the test passes. That test already rejects a back
    /// face at or in front of the candidate, so where the mesh is tie-free the
    /// executor draws only its front faces, tested `LessOrEqual` with no
    /// fragment shader (OpenCSG's SCS subtraction: front faces, then back
    /// faces); elsewhere it is `NearerThan` (`plan::scs`).
    ParityBeforeExit {
        /// The texture holding the candidate's depth.
        tex: Tex,
        /// The signed tie tolerance, as [`Fragment::NearerThan`]'s.
        eps: f32,
    },
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
    TieDepth {
        /// The signed tie tolerance, as the draw's it replaces.
        eps: f32,
    },
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
        /// The depth texture holding the visible surface's depth.
        tex: Tex,
        /// The tolerance of the depth-equal test (normalized depth).
        eps: f32,
        /// The faces the depth-equal form culls.
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
    BehindThan {
        /// The texture holding the candidate's depth.
        tex: Tex,
        /// The signed tie tolerance, as [`Fragment::NearerThan`]'s.
        eps: f32,
    },
    /// The depth of texture `tex` as the fragment depth, only where this
    /// fragment is behind it by more than the tolerance `eps` (the opposite of
    /// [`Fragment::NearerThan`]'s test, ties decided alike) and `tex` is not
    /// far; no colour output. SCS's clip and merge of a product with one
    /// positive primitive in one draw of its back faces (`plan::scs`). With
    /// `eps` 0 the test is exact and the program fetches one texel (the
    /// executor's rewrite where no face can tie, [`super::tie_free`]).
    MergeBehind {
        /// The texture holding the candidate's depth, written as the fragment depth.
        tex: Tex,
        /// The tie tolerance, as [`Fragment::NearerThan`]'s.
        eps: f32,
    },
    /// Full-screen copy of texture `src` into the fragment depth (`gl_FragDepth`),
    /// discarding pixels where `src` holds the far value 1.0 (nothing there).
    DepthFromTexture {
        /// The texture copied into the fragment depth.
        src: Tex,
    },
    /// Tolerant depth peeling: discard fragments not behind texture `prev` by more
    /// than `eps` (normalized depth; kept: `z - eps > prev`); write the fragment's
    /// depth into texture `out`. Depth-stencil ops apply to the kept fragments only.
    PeelTolerant {
        /// The texture holding the previous layer's depth.
        prev: Tex,
        /// The texture receiving this layer's depth.
        out: Tex,
        /// How far behind `prev` a kept fragment must be (normalized depth).
        eps: f32,
    },
    /// Full-screen copy of texture `src` into texture `out` at the pixels the draw's
    /// stencil (and depth) tests pass; the fragment depth is the rectangle's.
    CopyTexel {
        /// The texture read.
        src: Tex,
        /// The texture written.
        out: Tex,
    },
    /// Shaded colour and primitive id, only where the fragment depth equals texture
    /// `tex` at this pixel bit-exactly (other fragments are discarded before the
    /// depth test writes anything). Exact because `gl_Position` is invariant: a mesh
    /// redrawn with the same transform reproduces the depths a `Peel` recorded. CST
    /// merges a trimmed surface into the final image with it (Hable & Rossignac §4,
    /// Render(S)).
    ShadeAtDepth {
        /// The texture holding the depth the surface was peeled at.
        tex: Tex,
    },
    /// [`Fragment::ShadeAtDepth`] without colour targets: the depth only, where
    /// the fragment depth equals texture `tex` bit-exactly. A solid's CST merge,
    /// whose colour and id the final depth-equal shading
    /// ([`Fragment::ShadeNearDepth`]) overwrites at every pixel it wins.
    DepthAtDepth {
        /// The texture holding the depth the surface was peeled at.
        tex: Tex,
    },
}

/// One rasterization.
#[derive(Clone, Debug, PartialEq)]
pub struct Draw {
    /// What the draw rasterizes.
    pub geometry: Geometry,
    /// The scissor rectangle: where the draw may touch pixels.
    pub scissor: Scissor,
    /// The face orientation discarded before rasterization.
    pub cull: Cull,
    /// The depth-stencil image tested and written.
    pub ds: Ds,
    /// The depth test and write.
    pub depth: DepthState,
    /// `None`: stencil test disabled.
    pub stencil: Option<StencilState>,
    /// The fragment program: texture reads and tests, colour targets written.
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
    DepthStencil {
        /// The image cleared.
        ds: Ds,
        /// The normalized depth it holds after (`1.0`: nothing drawn yet).
        depth: f32,
        /// The stencil value it holds after (`0`: no label, even parity).
        stencil: u8,
    },
    /// A depth texture to a normalized depth value.
    Texture {
        /// The texture cleared.
        tex: Tex,
        /// The normalized depth it holds after.
        depth: f32,
    },
    /// Colour to the background, primitive id to 0.
    Color,
}

/// A data-dependent repeat: run `head`; stop when its `count_samples` draws passed
/// no sample (or after `max_iterations`); otherwise run `tail` and repeat.
#[derive(Clone, Debug, PartialEq)]
pub struct Loop {
    /// Steps run on every iteration: a peel, whose counted draws say whether a layer was left.
    pub head: Vec<Step>,
    /// Steps run after a head that passed samples, before the next iteration.
    pub tail: Vec<Step>,
    /// The most iterations run, whatever the counts (a bound on the depth complexity).
    pub max_iterations: u32,
}

/// One command of a plan; a plan runs its steps in order.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Starts a named pass group: a timestamp boundary in `stats.json` and a
    /// heading in the plan printout. Groups with the same name are summed.
    Pass(String),
    /// A whole-image clear.
    Clear(Clear),
    /// A rasterization.
    Draw(Draw),
    /// Copy one depth texture into another (same size and format).
    CopyTexture {
        /// The texture read.
        src: Tex,
        /// The texture written.
        dst: Tex,
    },
    /// Copy a depth-stencil image, depth and stencil, into another (same size
    /// and format) as a bound: the draws that follow are depth-tested against
    /// it, and no step reads `dst`'s depth as a surface at a pixel no later
    /// draw replaced (layered Goldfeather's peel starts at the output depth
    /// resolved so far). So it brings no faces a tolerant draw could tie with
    /// (`plan::tie_context`).
    CopyDepthBound {
        /// The depth-stencil image read.
        src: Ds,
        /// The depth-stencil image written.
        dst: Ds,
    },
    /// Copy the depth of a depth-stencil image into a depth texture.
    CopyDepthToTexture {
        /// The depth-stencil image whose depth is read.
        ds: Ds,
        /// The texture written.
        dst: Tex,
    },
    /// A data-dependent repeat (a peel loop).
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
    /// The frame's work, in execution order.
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
