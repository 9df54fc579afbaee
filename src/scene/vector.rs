//! Fixed-length number vectors of the scene file (docs/scene-format.md: `size`,
//! `rotate_deg`, `translate`, `scale`, camera `eye`/`target`/`up`).
//!
//! They are read as raw TOML values and checked here rather than by serde's
//! `[f64; 3]`, which (through `toml`) silently ignores extra elements: a
//! `size = [1.0, 1.0, 1.0, 4.0]` or `translate = [0, 0, 0, true]` must be an
//! error, and the loader wants to name the key path in it, which a serde error
//! inside an array cannot.

use toml::{Spanned, Value};

/// A vector key as written in the file, with its place; checked by [`vec3`] or
/// [`vec3_or_number`] once the loader knows its key path.
pub(super) type RawVec = Spanned<Value>;

const EXAMPLE: &str = "[1.0, 2.0, 3.0]";

/// A default vector as if written in the file (no place: defaults are valid).
pub(super) fn raw(v: [f64; 3]) -> RawVec {
    Spanned::new(0..0, Value::Array(v.map(Value::Float).to_vec()))
}

fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Float(f) => Some(*f),
        Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

fn describe(v: &Value) -> String {
    match v {
        Value::String(s) => format!("the string \"{}\"", s.escape_debug()),
        Value::Boolean(b) => format!("the boolean {b}"),
        Value::Array(a) => format!("an array of {} elements", a.len()),
        Value::Table(_) => "a table".to_string(),
        Value::Datetime(d) => format!("the date-time {d}"),
        Value::Float(f) => format!("the number {f}"),
        Value::Integer(i) => format!("the number {i}"),
    }
}

/// Exactly three numbers (integers are read as floats). The error says what was
/// found and how to write it; the caller adds the key path.
pub(super) fn vec3(v: &Value, what: &str) -> Result<[f64; 3], String> {
    let Value::Array(a) = v else {
        return Err(format!(
            "found {}: write an array of 3 numbers ({what}), e.g. {EXAMPLE}",
            describe(v)
        ));
    };
    if a.len() != 3 {
        return Err(format!(
            "has {} element{}: write exactly 3 numbers ({what}), e.g. {EXAMPLE}",
            a.len(),
            if a.len() == 1 { "" } else { "s" }
        ));
    }
    let mut out = [0.0; 3];
    for (i, (slot, e)) in out.iter_mut().zip(a).enumerate() {
        *slot = number(e).ok_or_else(|| {
            format!(
                "element {} is {}, not a number: write 3 numbers ({what}), e.g. {EXAMPLE}",
                i + 1,
                describe(e)
            )
        })?;
    }
    Ok(out)
}

/// A number (the same on every axis) or three numbers: `scale`.
pub(super) fn vec3_or_number(v: &Value, what: &str) -> Result<[f64; 3], String> {
    match number(v) {
        Some(x) => Ok([x; 3]),
        None => vec3(v, what).map_err(|e| {
            if matches!(v, Value::Array(_)) {
                e
            } else {
                format!(
                    "found {}: write a number or an array of 3 numbers ({what}), e.g. 2.0 or {EXAMPLE}",
                    describe(v)
                )
            }
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn val(s: &str) -> Value {
        let t: toml::Table = toml::from_str(&format!("v = {s}")).unwrap();
        t["v"].clone()
    }

    #[test]
    fn accepts_three_numbers_including_integers() {
        assert_eq!(vec3(&val("[1, 2.5, -3]"), "x").unwrap(), [1.0, 2.5, -3.0]);
        assert_eq!(vec3_or_number(&val("2"), "x").unwrap(), [2.0; 3]);
        assert_eq!(
            vec3_or_number(&val("[1, 2, 3]"), "x").unwrap(),
            [1.0, 2.0, 3.0]
        );
    }

    #[test]
    fn rejects_wrong_length_and_types() {
        for (src, needle) in [
            ("[1.0, 1.0, 1.0, 4.0]", "has 4 elements"),
            ("[1.0, 1.0]", "has 2 elements"),
            ("[]", "has 0 elements"),
            ("[0.0, 0.0, \"x\"]", "element 3 is the string \"x\""),
            ("[true, 0.0, 0.0]", "element 1 is the boolean true"),
            ("[[1.0], 0.0, 0.0]", "element 1 is an array"),
            ("\"1,2,3\"", "found the string"),
            ("{ x = 1 }", "found a table"),
            ("3.0", "found the number 3"),
        ] {
            let e = vec3(&val(src), "x, y, z").unwrap_err();
            assert!(e.contains(needle), "{src}: {e}");
            assert!(e.contains("e.g. [1.0, 2.0, 3.0]"), "{src}: {e}");
        }
        let e = vec3_or_number(&val("true"), "x").unwrap_err();
        assert!(e.contains("a number or an array of 3 numbers"), "{e}");
        let e = vec3_or_number(&val("[1, 2, 3, 4]"), "x").unwrap_err();
        assert!(e.contains("has 4 elements"), "{e}");
    }
}
