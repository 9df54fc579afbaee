//! The whole file to a [`Scene`]: names, primitives, solids and surfaces in
//! order, `[render]`, the camera last (it fits what is drawn), appearance keys;
//! `[csg] openscad` hands the model to `super::super::openscad`.

use std::collections::HashMap;

use super::toml_model::{CameraT, FileT, KeepT};
use super::{valid_name, LoadOptions, Loader, SceneError, MAX_SIZE};
use crate::scene::shapes;
use crate::scene::validate::{check_closed, signed_volume};
use crate::scene::vector;
use crate::scene::{Keep, Mesh, Primitive, RenderSettings, Scene, Shape, Solid, Surface};

impl Loader<'_> {
    pub(super) fn run(mut self, opts: &LoadOptions) -> Result<Scene, SceneError> {
        let file: FileT = toml::from_str(self.text).map_err(|e| self.syntax(e))?;
        if file
            .csg
            .as_ref()
            .is_some_and(|c| c.get_ref().openscad.is_some())
        {
            return self.run_openscad(file, opts);
        }

        // Names: one namespace for primitives and surfaces.
        let mut names: HashMap<String, String> = HashMap::new();
        let tables = file
            .primitive
            .iter()
            .enumerate()
            .map(|(i, p)| ("primitive", i, p))
            .chain(
                file.surface
                    .iter()
                    .enumerate()
                    .map(|(i, s)| ("surface", i, s)),
            );
        for (kind, i, t) in tables {
            let name = &t.get_ref().name;
            let key = format!("{kind}[{}] \"{name}\"", i + 1);
            if !valid_name(name) {
                return Err(self.invalid(
                    self.line(t.span()),
                    format!("{key}: name"),
                    format!(
                        "\"{name}\" is not a valid name: use a letter or `_` followed by letters, digits or `_` (e.g. \"A\", \"hole_2\")"
                    ),
                ));
            }
            if let Some(prev) = names.insert(name.clone(), key.clone()) {
                return Err(self.invalid(
                    self.line(t.span()),
                    format!("{key}: name"),
                    format!(
                        "\"{name}\" is already the name of {}; names must be unique in the file",
                        prev.split(' ').next().unwrap_or(&prev)
                    ),
                ));
            }
        }
        let prim_index: HashMap<&str, u32> = file
            .primitive
            .iter()
            .enumerate()
            .map(|(i, p)| (p.get_ref().name.as_str(), i as u32))
            .collect();

        // Primitives (local meshes kept for validation in file coordinates).
        let mut primitives = Vec::with_capacity(file.primitive.len());
        let mut local_meshes = Vec::with_capacity(file.primitive.len());
        for (i, t) in file.primitive.iter().enumerate() {
            let p = t.get_ref();
            let key = format!("primitive[{}] \"{}\"", i + 1, p.name);
            let line = self.line(t.span());
            for (k, present) in [
                ("trim", p.trim.is_some()),
                ("keep", p.keep.is_some()),
                ("paint_color", p.paint_color.is_some()),
            ] {
                if present {
                    return Err(self.invalid(
                        line,
                        format!("{key}: {k}"),
                        format!("`{k}` applies only to a [[surface]]; remove it or make this table a [[surface]]"),
                    ));
                }
            }
            let (shape, local, transform) = self.build_shape(p, &key, line)?;
            let mesh = shapes::apply_transform(&local, &transform);
            primitives.push(Primitive {
                name: p.name.clone(),
                shape,
                transform,
                mesh,
                color: p.color.map_or([0xc0, 0xc0, 0xc0], |c| c.0),
                used: false,
            });
            local_meshes.push(local);
        }

        // Expressions.
        let mut solids = Vec::new();
        if let Some(csg) = &file.csg {
            if let Some(s) = file.solid.first() {
                return Err(self.invalid(
                    self.line(s.span()),
                    "solid",
                    "[csg] and [[solid]] cannot be used together: move the [csg] expression into a [[solid]] table, or use only [csg]",
                ));
            }
            let line = self.line(csg.span());
            let src = csg.get_ref().expr.as_deref().ok_or_else(|| {
                self.invalid(
                    line,
                    "csg: expr",
                    "missing: [csg] needs `expr = \"...\"` over the primitive names, or `openscad = \"model.csg\"`",
                )
            })?;
            if csg.get_ref().skip_unsupported.is_some() {
                return Err(self.invalid(
                    line,
                    "csg: skip_unsupported",
                    "`skip_unsupported` applies only with `openscad = \"model.csg\"`; remove it",
                ));
            }
            let expr = self.parse_expr(src, &prim_index, line, "csg: expr")?;
            self.check_bounded(&expr, line, "csg: expr", src)?;
            solids.push(Solid {
                name: file.name.clone().unwrap_or_else(|| "csg".to_string()),
                expr,
            });
        }
        let mut solid_names: HashMap<&str, usize> = HashMap::new();
        for (i, t) in file.solid.iter().enumerate() {
            let s = t.get_ref();
            let line = self.line(t.span());
            let key = format!("solid[{}] \"{}\"", i + 1, s.name);
            if let Some(prev) = solid_names.insert(&s.name, i) {
                return Err(self.invalid(
                    line,
                    format!("{key}: name"),
                    format!(
                        "\"{}\" is already the name of solid[{}]; solid names must be unique",
                        s.name,
                        prev + 1
                    ),
                ));
            }
            let k = format!("{key}: expr");
            let expr = self.parse_expr(&s.expr, &prim_index, line, &k)?;
            self.check_bounded(&expr, line, &k, &s.expr)?;
            solids.push(Solid {
                name: s.name.clone(),
                expr,
            });
        }

        // Surfaces.
        let mut surfaces = Vec::with_capacity(file.surface.len());
        for (i, t) in file.surface.iter().enumerate() {
            let s = t.get_ref();
            let line = self.line(t.span());
            let key = format!("surface[{}] \"{}\"", i + 1, s.name);
            if s.alpha.is_some() {
                return Err(self.invalid(
                    line,
                    format!("{key}: alpha"),
                    "`alpha` applies to a [[primitive]], a [[solid]], [csg] or [render]; surfaces are drawn opaque: remove it",
                ));
            }
            let trim_src = s.trim.as_deref().ok_or_else(|| {
                self.invalid(
                    line,
                    format!("{key}: trim"),
                    "missing `trim`: give the trimming volume over primitive names, e.g. trim = \"A + B\"",
                )
            })?;
            let trim = self.parse_expr(trim_src, &prim_index, line, &format!("{key}: trim"))?;
            let (shape, local, transform) = self.build_shape(s, &key, line)?;
            let mesh = shapes::apply_transform(&local, &transform);
            surfaces.push(Surface {
                name: s.name.clone(),
                shape,
                transform,
                mesh,
                color: s.color.map_or([0xc0, 0xc0, 0xc0], |c| c.0),
                trim,
                keep: match s.keep.unwrap_or(KeepT::In) {
                    KeepT::In => Keep::In,
                    KeepT::Out => Keep::Out,
                    KeepT::Paint => Keep::Paint,
                },
                paint_color: s.paint_color.map_or([0xc0, 0x20, 0x20], |c| c.0),
            });
        }
        if solids.is_empty() && surfaces.is_empty() {
            return Err(self.invalid(
                None,
                "csg",
                "nothing to draw: add a [csg] table with `expr = \"...\"`, [[solid]] tables, or [[surface]] tables",
            ));
        }

        // Which primitives are drawn; those must bound solids.
        for e in solids
            .iter()
            .map(|s| &s.expr)
            .chain(surfaces.iter().map(|s| &s.trim))
        {
            for p in e.leaves() {
                primitives[p as usize].used = true;
            }
        }
        for (i, p) in primitives.iter().enumerate() {
            let line = self.line(file.primitive[i].span());
            let key = format!("primitive[{}] \"{}\"", i + 1, p.name);
            if !p.used {
                self.warnings.push(format!(
                    "{}: {key} is not named by any expression and is not drawn",
                    self.path.display()
                ));
                continue;
            }
            if matches!(p.shape, Shape::Mesh { .. }) {
                let local = &local_meshes[i];
                if let Err(problem) = check_closed(local) {
                    return Err(self.invalid(
                        line,
                        format!("{key}: path"),
                        format!(
                            "the mesh is used in a CSG expression but is not a closed, consistently oriented surface: {}",
                            problem.describe(local)
                        ),
                    ));
                }
                let v = signed_volume(local);
                if v < 0.0 {
                    return Err(self.invalid(
                        line,
                        format!("{key}: path"),
                        "the mesh is inside out (negative signed volume: its triangles wind clockwise seen from outside); reverse the vertex order of every face",
                    ));
                }
                if v == 0.0 {
                    return Err(self.invalid(
                        line,
                        format!("{key}: path"),
                        "the mesh encloses no volume",
                    ));
                }
            }
        }

        self.finish(file, opts, primitives, solids, surfaces, None)
    }

    /// `[csg] openscad = "model.csg"`: the OpenSCAD model is the whole scene.
    pub(super) fn run_openscad(
        mut self,
        file: FileT,
        opts: &LoadOptions,
    ) -> Result<Scene, SceneError> {
        let csg = file.csg.as_ref().expect("checked by the caller");
        let line = self.line(csg.span());
        let c = csg.get_ref();
        let rel = c.openscad.as_deref().expect("checked by the caller");
        if c.expr.is_some() {
            return Err(self.invalid(
                line,
                "csg: openscad",
                "`expr` and `openscad` cannot be used together: the OpenSCAD model is the whole solid; remove `expr`",
            ));
        }
        for (table, span) in [
            ("[[primitive]]", file.primitive.first().map(|t| t.span())),
            ("[[solid]]", file.solid.first().map(|t| t.span())),
            ("[[surface]]", file.surface.first().map(|t| t.span())),
        ] {
            if let Some(span) = span {
                return Err(self.invalid(
                    self.line(span),
                    table.trim_matches(['[', ']']),
                    format!("{table} cannot be used with [csg] openscad: the .csg file is the whole model; remove the table or the `openscad` key"),
                ));
            }
        }
        let skip = self.skip_unsupported || c.skip_unsupported.unwrap_or(false);
        let model = match self.inline_csg {
            Some(text) => crate::scene::openscad::model_from_str(text, self.path, skip)?,
            None => {
                let full = self.dir.join(rel);
                crate::scene::openscad::read_model(&full, skip).map_err(|e| match e {
                    SceneError::Read { path, source } => self.invalid(
                        line,
                        "csg: openscad",
                        format!(
                            "cannot read {}: {source} (the path is relative to the scene file's folder)",
                            path.display()
                        ),
                    ),
                    e => e,
                })?
            }
        };
        self.warnings.extend(model.warnings);
        let solids = vec![Solid {
            name: file.name.clone().unwrap_or_else(|| "csg".to_string()),
            expr: model.expr,
        }];
        let mut scene = self.finish(
            file,
            opts,
            model.primitives,
            solids,
            Vec::new(),
            Some(&model.background),
        )?;
        scene.appearance.background = model.background;
        Ok(scene)
    }

    /// Render settings and the camera, then the scene. `openscad`: OpenSCAD's
    /// defaults (its view direction with Z up, field of view and background),
    /// and the model's `%` parts, which the fitted camera holds too (they are
    /// drawn where the algorithm draws transparency).
    pub(super) fn finish(
        mut self,
        file: FileT,
        opts: &LoadOptions,
        primitives: Vec<Primitive>,
        solids: Vec<Solid>,
        surfaces: Vec<Surface>,
        openscad: Option<&[crate::scene::openscad::background::Background]>,
    ) -> Result<Scene, SceneError> {
        // Render settings.
        let r = file
            .render
            .as_ref()
            .map(|r| (r.get_ref(), self.line(r.span())));
        let mut render = RenderSettings {
            width: r.and_then(|r| r.0.width).unwrap_or(800),
            height: r.and_then(|r| r.0.height).unwrap_or(800),
            background: r.and_then(|r| r.0.background).map_or(
                if openscad.is_some() {
                    crate::scene::openscad::DEFAULT_BACKGROUND
                } else {
                    [0x20, 0x20, 0x20]
                },
                |c| c.0,
            ),
            samples: r.and_then(|r| r.0.samples).unwrap_or(1),
        };
        if ![1, 2, 4, 8].contains(&render.samples) {
            return Err(self.invalid(
                r.and_then(|r| r.1),
                "render: samples",
                format!("{} is not a sample count: use 1, 2, 4 or 8", render.samples),
            ));
        }
        for (k, v) in [("width", render.width), ("height", render.height)] {
            if v == 0 || v > MAX_SIZE {
                return Err(self.invalid(
                    r.and_then(|r| r.1),
                    format!("render: {k}"),
                    format!("{v} is out of range: the image size must be 1 to {MAX_SIZE} pixels"),
                ));
            }
        }
        if let Some((w, h)) = opts.size {
            if w == 0 || h == 0 || w > MAX_SIZE || h > MAX_SIZE {
                return Err(self.invalid(
                    None,
                    "--size",
                    format!("{w}x{h} is out of range: each side must be 1 to {MAX_SIZE} pixels"),
                ));
            }
            render.width = w;
            render.height = h;
        }

        let mut appearance =
            self.appearance(&file, r.and_then(|r| r.0.alpha), r.and_then(|r| r.1))?;

        // Huge but finite sizes would make an infinite camera or GPU copies.
        let named = primitives
            .iter()
            .filter(|p| p.used)
            .map(|p| ("primitive", &p.name, &p.mesh))
            .chain(surfaces.iter().map(|s| ("surface", &s.name, &s.mesh)));
        for (kind, name, mesh) in named {
            if let Some(v) = mesh
                .positions
                .iter()
                .find(|v| !(v.abs().max_element() <= super::MAX_COORD))
            {
                return Err(self.invalid(
                    None,
                    format!("{kind} \"{name}\""),
                    format!(
                        "a vertex lies at ({:e}, {:e}, {:e}), beyond ±{:e}: give sizes, radii, translations and mesh coordinates below that (scale the scene down)",
                        v.x,
                        v.y,
                        v.z,
                        super::MAX_COORD
                    ),
                ));
            }
        }
        let drawn: Vec<&Mesh> = primitives
            .iter()
            .filter(|p| p.used)
            .map(|p| &p.mesh)
            .chain(surfaces.iter().map(|s| &s.mesh))
            .collect();
        // The camera frames the `%` parts too.
        let fitted: Vec<&Mesh> = drawn
            .iter()
            .copied()
            .chain(
                openscad
                    .unwrap_or_default()
                    .iter()
                    .flat_map(|b| b.primitives.iter().map(|p| &p.mesh)),
            )
            .collect();
        let default = if openscad.is_some() {
            CameraT {
                eye: Some(vector::raw(
                    crate::scene::openscad::default_view_dir().to_array(),
                )),
                up: Some(vector::raw([0.0, 0.0, 1.0])),
                fov_y_deg: Some(crate::scene::openscad::DEFAULT_FOV_Y_DEG),
                ..CameraT::fitted_default()
            }
        } else {
            CameraT::fitted_default()
        };
        let camera = self.camera(file.camera.as_ref(), &default, &render, &fitted)?;
        if let Some(l) = &file.light {
            let light = crate::scene::light::resolve(l.get_ref(), drawn.iter().copied())
                .map_err(|(key, m)| self.invalid(self.line(l.span()), key, m))?;
            appearance.light = Some(light);
        }

        Ok(Scene {
            name: file.name,
            path: self.path.to_path_buf(),
            camera,
            render,
            primitives,
            solids,
            surfaces,
            warnings: self.warnings,
            appearance,
        })
    }

    /// The `alpha` keys of the primitives, the solids (`[csg]` first) and
    /// `[render]` (extension, [`crate::scene::Appearance`]).
    pub(super) fn appearance(
        &self,
        file: &FileT,
        render_alpha: Option<f64>,
        render_line: Option<usize>,
    ) -> Result<crate::scene::Appearance, SceneError> {
        let primitive_alpha = file
            .primitive
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let key = format!("primitive[{}] \"{}\"", i + 1, t.get_ref().name);
                self.alpha(t.get_ref().alpha, self.line(t.span()), &key)
            })
            .collect::<Result<_, _>>()?;
        let csg = file
            .csg
            .iter()
            .map(|c| self.alpha(c.get_ref().alpha, self.line(c.span()), "csg"));
        let solids = file.solid.iter().enumerate().map(|(i, t)| {
            let key = format!("solid[{}] \"{}\"", i + 1, t.get_ref().name);
            self.alpha(t.get_ref().alpha, self.line(t.span()), &key)
        });
        Ok(crate::scene::Appearance {
            alpha: self.alpha(render_alpha, render_line, "render")?,
            solid_alpha: csg.chain(solids).collect::<Result<_, _>>()?,
            primitive_alpha,
            interference: file
                .render
                .as_ref()
                .and_then(|r| r.get_ref().interference)
                .unwrap_or(false),
            style: match file
                .render
                .as_ref()
                .and_then(|r| r.get_ref().style.as_deref())
            {
                Some(s) => crate::scene::style::parse_style(s)
                    .map_err(|m| self.invalid(render_line, "render: style", m))?,
                None => Default::default(),
            },
            light: None,
            background: Vec::new(),
        })
    }

    /// An optional `alpha` key, checked to lie in (0, 1].
    pub(super) fn alpha(
        &self,
        a: Option<f64>,
        line: Option<usize>,
        key: &str,
    ) -> Result<Option<f64>, SceneError> {
        a.map(crate::scene::appearance::check_alpha)
            .transpose()
            .map_err(|m| self.invalid(line, format!("{key}: alpha"), m))
    }
}
