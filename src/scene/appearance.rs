//! How a scene looks beyond the default opaque shading: opacity (`alpha`) of the
//! primitives, the solids and the whole render (Hable & Rossignac §6, transparent
//! CSG). An optional part of the scene format (docs/scene-format.md).
//!
//! Kept apart from [`super::Primitive`] and [`super::Solid`] so the basic
//! structures (and every literal building them) are unchanged; all-`None` means
//! the default opaque rendering.
#![deny(unsafe_code)]

/// Opacities in `(0, 1]`; `None` where the scene does not say.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Appearance {
    /// `[render] alpha`, or `--alpha` (the flag wins).
    pub alpha: Option<f64>,
    /// `alpha` of each `[[solid]]` (or `[csg]`), in solid order; may be shorter
    /// than the solids (missing entries are `None`).
    pub solid_alpha: Vec<Option<f64>>,
    /// `alpha` of each `[[primitive]]`, in file order; may be shorter.
    pub primitive_alpha: Vec<Option<f64>>,
    /// `[render] interference = true` (or `--interference`): show where the
    /// assembly's solids intersect.
    pub interference: bool,
    /// `[render] style` (or `--style`): how `color.png` shows the layers.
    pub style: super::style::Style,
    /// `[light]`: the light that casts the solids' shadows (docs/shadows.md).
    pub light: Option<super::light::Light>,
    /// An OpenSCAD model's `%` background parts, not drawn until
    /// [`super::openscad::background::show`] adds them as see-through solids.
    pub background: Vec<super::openscad::background::Background>,
}

impl Appearance {
    /// The opacity of a boundary point of solid `solid` on primitive `prim`
    /// (0-based): the primitive's alpha, else the solid's, else the render's, else 1.
    pub fn alpha_of(&self, prim: u32, solid: u32) -> f64 {
        let get = |v: &[Option<f64>], i: u32| v.get(i as usize).copied().flatten();
        get(&self.primitive_alpha, prim)
            .or_else(|| get(&self.solid_alpha, solid))
            .or(self.alpha)
            .unwrap_or(1.0)
    }

    /// Whether anything is see-through (some alpha below 1).
    pub fn is_transparent(&self) -> bool {
        self.alpha
            .into_iter()
            .chain(self.solid_alpha.iter().flatten().copied())
            .chain(self.primitive_alpha.iter().flatten().copied())
            .any(|a| a < 1.0)
    }
}

/// Checks an opacity value: a number in `(0, 1]`. The error says the fix.
pub fn check_alpha(a: f64) -> Result<f64, String> {
    if a.is_finite() && a > 0.0 && a <= 1.0 {
        Ok(a)
    } else {
        Err(format!(
            "alpha {a} is out of range: give an opacity in (0, 1], e.g. 0.4 (1 is opaque)"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn precedence_primitive_solid_render() {
        let mut a = Appearance::default();
        assert_eq!(a.alpha_of(0, 0), 1.0);
        assert!(!a.is_transparent());
        a.alpha = Some(0.5);
        a.solid_alpha = vec![None, Some(0.25)];
        a.primitive_alpha = vec![Some(0.75)];
        assert_eq!(a.alpha_of(0, 1), 0.75);
        assert_eq!(a.alpha_of(1, 1), 0.25);
        assert_eq!(a.alpha_of(1, 0), 0.5);
        assert_eq!(a.alpha_of(7, 9), 0.5);
        assert!(a.is_transparent());
        let opaque = Appearance {
            alpha: Some(1.0),
            ..Default::default()
        };
        assert!(!opaque.is_transparent());
    }

    fn load(src: &str) -> Result<crate::scene::Scene, String> {
        crate::scene::load_str(
            src,
            std::path::Path::new("/tmp/t/alpha.toml"),
            &Default::default(),
        )
        .map_err(|e| e.to_string())
    }

    const HEAD: &str = "[camera]\neye = [3.0, 2.0, 4.0]\n[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [1.0, 1.0, 1.0]\n";

    #[test]
    fn alpha_keys_load_and_bad_values_are_named() {
        let s = load(&format!(
            "{HEAD}alpha = 0.5\n[[primitive]]\nname = \"B\"\nshape = \"sphere\"\nradius = 0.3\n\
             [[solid]]\nname = \"s\"\nexpr = \"A\"\n[[solid]]\nname = \"t\"\nexpr = \"B\"\nalpha = 0.25\n\
             [render]\nalpha = 0.8\ninterference = true\n"
        ))
        .unwrap();
        assert!(s.appearance.interference);
        let a = &s.appearance;
        assert_eq!(a.primitive_alpha, vec![Some(0.5), None]);
        assert_eq!(a.solid_alpha, vec![None, Some(0.25)]);
        assert_eq!(a.alpha, Some(0.8));
        let s = load(&format!("{HEAD}[csg]\nexpr = \"A\"\nalpha = 0.3\n")).unwrap();
        assert_eq!(s.appearance.solid_alpha, vec![Some(0.3)]);
        assert!(!s.appearance.interference);
        let e = load(&format!(
            "{HEAD}[csg]\nexpr = \"A\"\n[render]\ninterference = \"yes\"\n"
        ))
        .unwrap_err();
        assert!(e.contains("interference") && e.contains("bool"), "{e}");
        let e = load(&format!("{HEAD}alpha = 1.5\n[csg]\nexpr = \"A\"\n")).unwrap_err();
        assert!(
            e.contains("primitive[1] \"A\": alpha") && e.contains("(0, 1]"),
            "{e}"
        );
        let e = load(&format!("{HEAD}[csg]\nexpr = \"A\"\n[render]\nalpha = 0\n")).unwrap_err();
        assert!(e.contains("render: alpha"), "{e}");
        let e = load(&format!(
            "{HEAD}[csg]\nexpr = \"A\"\n[[surface]]\nname = \"S\"\nshape = \"box\"\nsize = [1, 1, 1]\ntrim = \"A\"\nalpha = 0.5\n"
        ))
        .unwrap_err();
        assert!(e.contains("surface[1] \"S\": alpha"), "{e}");
    }

    #[test]
    fn alpha_range() {
        assert!(check_alpha(1.0).is_ok() && check_alpha(0.01).is_ok());
        for bad in [0.0, -0.1, 1.5, f64::NAN] {
            assert!(check_alpha(bad).unwrap_err().contains("(0, 1]"));
        }
    }
}
