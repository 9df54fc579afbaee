//! The rendering style of `color.png` (Kirsch, Nienhaus & Döllner §4.5, §5.3–5.4):
//! `--style` or `[render] style`. An optional setting of the scene format
//! (default `opaque`: the plain image); the composition itself is `render::style`.
#![deny(unsafe_code)]

/// How the layers of the solid become `color.png`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Style {
    /// The plain opaque image (transparent when some `alpha` is below 1).
    #[default]
    Opaque,
    /// Order-independent transparency: the layers blended (§4.5).
    Transparent,
    /// Blueprint, depth-complexity cueing: every layer's edges blended back to
    /// front in a bluish tone over a faint fill (§5.3).
    Blueprint,
    /// Blueprint as a wireframe: only edge pixels (a threshold), visible edges
    /// bright, hidden ones dim (§5.3).
    Wireframe,
    /// Edge-enhanced transparency: each layer's colour darkened on its edges,
    /// then blended (§5.4).
    BlueprintTransparent,
}

impl Style {
    pub(crate) const ALL: [Style; 5] = [
        Style::Opaque,
        Style::Transparent,
        Style::Blueprint,
        Style::Wireframe,
        Style::BlueprintTransparent,
    ];

    /// The name on the command line (`--style`).
    pub fn name(self) -> &'static str {
        match self {
            Style::Opaque => "opaque",
            Style::Transparent => "transparent",
            Style::Blueprint => "blueprint",
            Style::Wireframe => "wireframe",
            Style::BlueprintTransparent => "blueprint-transparent",
        }
    }

    /// Whether the style needs the layers of the solid.
    pub fn layered(self) -> bool {
        self != Style::Opaque
    }

    /// Whether the style needs the layers' edge maps.
    pub fn edges(self) -> bool {
        matches!(
            self,
            Style::Blueprint | Style::Wireframe | Style::BlueprintTransparent
        )
    }
}

/// Parses a style name; the error lists the names.
pub fn parse_style(s: &str) -> Result<Style, String> {
    Style::ALL
        .into_iter()
        .find(|st| st.name() == s.trim())
        .ok_or_else(|| {
            let names: Vec<&str> = Style::ALL.iter().map(|s| s.name()).collect();
            format!(
                "unknown style '{s}': use one of {} (e.g. blueprint)",
                names.join(", ")
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_list_the_choices() {
        for s in Style::ALL {
            assert_eq!(parse_style(s.name()), Ok(s));
        }
        let e = parse_style("blue").unwrap_err();
        assert!(
            e.contains("'blue'") && e.contains("blueprint-transparent"),
            "{e}"
        );
        assert!(!Style::Opaque.layered() && Style::Transparent.layered());
        assert!(!Style::Transparent.edges() && Style::Wireframe.edges());
    }

    #[test]
    fn render_style_key_loads_and_a_bad_one_is_named() {
        let load = |extra: &str| {
            crate::scene::load_str(
                &format!(
                    "[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [1.0, 1.0, 1.0]\n\
                     [csg]\nexpr = \"A\"\n[render]\n{extra}"
                ),
                std::path::Path::new("/tmp/t/style.toml"),
                &Default::default(),
            )
            .map_err(|e| e.to_string())
        };
        assert_eq!(load("").unwrap().appearance.style, Style::Opaque);
        let s = load("style = \"blueprint-transparent\"\n").unwrap();
        assert_eq!(s.appearance.style, Style::BlueprintTransparent);
        let e = load("style = \"sketch\"\n").unwrap_err();
        assert!(
            e.contains("style.toml:") && e.contains("render: style") && e.contains("wireframe"),
            "{e}"
        );
    }
}
