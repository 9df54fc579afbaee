//! Checked values: vectors, finite and positive numbers, expressions over the
//! primitive names (bounded where a solid needs it), and the mesh memory charged
//! against the budget.

use glam::DVec3;
use std::collections::HashMap;

use super::{is_bounded, parse_expr, Loader, SceneError};
use crate::csg::Expr;
use crate::scene::vector::{self, RawVec};

impl Loader<'_> {
    pub(super) fn parse_expr(
        &self,
        src: &str,
        prims: &HashMap<&str, u32>,
        line: Option<usize>,
        key: &str,
    ) -> Result<Expr, SceneError> {
        parse_expr(src, prims).map_err(|e| self.invalid(line, key, e))
    }

    pub(super) fn check_bounded(
        &self,
        e: &Expr,
        line: Option<usize>,
        key: &str,
        src: &str,
    ) -> Result<(), SceneError> {
        if is_bounded(e) {
            return Ok(());
        }
        Err(self.invalid(
            line,
            key,
            format!(
                "{} is unbounded (it contains every point far from all primitives, as `!A` or `!A + B` do); \
                 a solid must be bounded: use a complement only where it is intersected with a bounded term, \
                 e.g. `B !A` (= `B - A`)",
                excerpt(src, 80)
            ),
        ))
    }

    /// Adds a mesh's estimated bytes to the scene's and refuses the scene when the
    /// total exceeds the memory budget, before the mesh is built.
    pub(super) fn charge(
        &self,
        line: Option<usize>,
        key: String,
        what: impl FnOnce() -> String,
        bytes: u64,
        fix: &str,
    ) -> Result<(), SceneError> {
        let total = self.mesh_bytes.get().saturating_add(bytes);
        self.mesh_bytes.set(total);
        crate::budget::current()
            .check(what, total, fix)
            .map_err(|e| self.invalid(line, key, e.to_string()))
    }

    /// A fixed-length vector key (`what` names its components in the fix), located
    /// at its own line.
    pub(super) fn vec3(
        &self,
        raw: &RawVec,
        key: &str,
        what: &str,
        number_ok: bool,
    ) -> Result<DVec3, SceneError> {
        let line = self.line(raw.span());
        let v = if number_ok {
            vector::vec3_or_number(raw.get_ref(), what)
        } else {
            vector::vec3(raw.get_ref(), what)
        }
        .map_err(|m| self.invalid(line, key, m))?;
        self.finite3(v, line, key)
    }

    pub(super) fn finite3(
        &self,
        v: [f64; 3],
        line: Option<usize>,
        key: &str,
    ) -> Result<DVec3, SceneError> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(DVec3::from_array(v))
        } else {
            Err(self.invalid(line, key, format!("{v:?} must be finite numbers")))
        }
    }

    pub(super) fn positive(
        &self,
        v: Option<f64>,
        line: Option<usize>,
        key: &str,
        shape: &str,
        what: &str,
    ) -> Result<f64, SceneError> {
        let v = v.ok_or_else(|| {
            self.invalid(
                line,
                key,
                format!(
                    "missing: a {shape} needs `{}` ({what})",
                    key.rsplit(' ').next().unwrap_or(key)
                ),
            )
        })?;
        if !(v.is_finite() && v > 0.0) {
            return Err(self.invalid(line, key, format!("{v} must be a positive finite number")));
        }
        Ok(v)
    }
}

/// `src`, quoted, if it has at most `max` characters, else its first and last characters
/// around an ellipsis and its length: an error about a generated 10⁵-term
/// expression names it without repeating it.
pub(super) fn excerpt(src: &str, max: usize) -> String {
    let n = src.chars().count();
    if n <= max {
        return format!("\"{src}\"");
    }
    let head: String = src.chars().take(max * 3 / 4).collect();
    let tail: String = src.chars().skip(n - max / 4).collect();
    format!("\"{head} … {tail}\" ({n} characters)")
}

#[cfg(test)]
mod tests {
    use super::excerpt;

    #[test]
    fn excerpt_keeps_short_text_and_cuts_long_text_at_char_boundaries() {
        assert_eq!(excerpt("!A + B", 80), "\"!A + B\"");
        let long = "é".repeat(1000);
        let e = excerpt(&long, 80);
        assert!(e.starts_with(&format!("\"{}", "é".repeat(60))), "{e}");
        assert!(e.contains("(1000 characters)"), "{e}");
        assert!(e.chars().count() < 110, "{e}");
    }
}
