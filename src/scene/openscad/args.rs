//! A node's arguments, named or positional, read as typed values with located
//! errors (`inf`/`nan` in geometry, wrong types, unknown positions).

use glam::DVec3;
use std::collections::HashMap;

use super::parse::{Node, Value, ValueKind};
use super::ScadError;

/// The arguments of one node, resolved against the node's positional order.
pub struct Args<'a> {
    node: &'a Node,
    named: HashMap<&'a str, &'a Value>,
}

impl<'a> Args<'a> {
    /// `positional` names the parameters in OpenSCAD's order (`cube(size,
    /// center)`); `known` lists further named parameters that are accepted.
    /// Parameters that are neither are reported in `warnings`; `$` variables and
    /// `convexity` (a preview hint) are accepted on every node.
    pub fn new(
        node: &'a Node,
        positional: &[&'static str],
        known: &[&'static str],
        warnings: &mut Vec<String>,
    ) -> Result<Self, ScadError> {
        let mut named: HashMap<&str, &Value> = HashMap::new();
        let mut k = 0;
        for a in &node.args {
            let name = match &a.name {
                Some(n) => n.as_str(),
                None => {
                    let n = positional.get(k).ok_or_else(|| {
                        ScadError::new(
                            a.pos,
                            format!(
                                "`{}` takes {} positional argument(s) ({}); name this one, e.g. `r = 2`",
                                node.name,
                                positional.len(),
                                if positional.is_empty() { "none".to_string() } else { positional.join(", ") }
                            ),
                        )
                    })?;
                    k += 1;
                    *n
                }
            };
            if named.insert(name, &a.value).is_some() {
                return Err(ScadError::new(
                    a.pos,
                    format!("`{name}` is given twice to `{}`: keep one", node.name),
                ));
            }
            if !(positional.iter().chain(known).any(|p| *p == name)
                || name.starts_with('$')
                || name == "convexity")
            {
                warnings.push(format!(
                    "{}:{}: `{}` has no parameter `{name}`; it is ignored",
                    a.pos.line, a.pos.col, node.name
                ));
            }
        }
        // OpenSCAD reads `inf` and `nan` in a `.csg` as unknown variables,
        // that is undef: the parameter takes its default. `multmatrix`'s `m`
        // (entry by entry) and `polyhedron`'s `points` (the object is dropped)
        // are read by their nodes.
        let own = |name: &str| {
            matches!(
                (node.name.as_str(), name),
                ("multmatrix", "m") | ("polyhedron", "points") | ("polygon", "points")
            )
        };
        let mut bad: Vec<(&str, &Value)> = named
            .iter()
            .filter(|(n, v)| has_non_finite(v) && !own(n))
            .map(|(n, v)| (*n, *v))
            .collect();
        bad.sort_by_key(|(_, v)| (v.pos.line, v.pos.col));
        for (name, v) in bad {
            named.remove(name);
            warnings.push(format!(
                "{}:{}: `{name}` of `{}` holds an infinite or NaN number, which OpenSCAD reads as undef; its default is used, as in OpenSCAD",
                v.pos.line, v.pos.col, node.name
            ));
        }
        Ok(Args { node, named })
    }

    /// The value of `name`, `undef` counting as absent.
    pub fn get(&self, name: &str) -> Option<&'a Value> {
        self.named
            .get(name)
            .copied()
            .filter(|v| v.kind != ValueKind::Undef)
    }

    fn what(&self, name: &str) -> String {
        format!("`{name}` of `{}`", self.node.name)
    }

    pub fn number(&self, name: &str) -> Result<Option<f64>, ScadError> {
        self.get(name)
            .map(|v| number(v, &self.what(name)))
            .transpose()
    }

    pub fn boolean(&self, name: &str) -> Result<Option<bool>, ScadError> {
        self.get(name)
            .map(|v| match v.kind {
                ValueKind::Bool(b) => Ok(b),
                ValueKind::Number(n) => Ok(n != 0.0),
                _ => Err(ScadError::new(
                    v.pos,
                    format!("{} must be true or false", self.what(name)),
                )),
            })
            .transpose()
    }
}

/// Whether the value holds an infinite or NaN number anywhere.
pub fn has_non_finite(v: &Value) -> bool {
    match &v.kind {
        ValueKind::Number(n) => !n.is_finite(),
        ValueKind::Vector(items) => items.iter().any(has_non_finite),
        _ => false,
    }
}

/// A finite number: `inf` and `nan` cannot make geometry.
pub fn number(v: &Value, what: &str) -> Result<f64, ScadError> {
    match v.kind {
        ValueKind::Number(n) if n.is_finite() => Ok(n),
        ValueKind::Number(n) => Err(ScadError::new(
            v.pos,
            format!(
                "{what} is {n}: infinite or NaN numbers cannot make geometry; give a finite number"
            ),
        )),
        _ => Err(ScadError::new(v.pos, format!("{what} must be a number"))),
    }
}

pub fn vector<'v>(v: &'v Value, what: &str) -> Result<&'v [Value], ScadError> {
    match &v.kind {
        ValueKind::Vector(items) => Ok(items),
        _ => Err(ScadError::new(
            v.pos,
            format!("{what} must be a vector such as [1, 2, 3]"),
        )),
    }
}

pub fn numbers(v: &Value, what: &str) -> Result<Vec<f64>, ScadError> {
    vector(v, what)?.iter().map(|x| number(x, what)).collect()
}

/// A 3-vector of finite numbers.
pub fn vec3(v: &Value, what: &str) -> Result<DVec3, ScadError> {
    let n = numbers(v, what)?;
    match n[..] {
        [x, y, z] => Ok(DVec3::new(x, y, z)),
        _ => Err(ScadError::new(
            v.pos,
            format!("{what} must have 3 numbers [x, y, z], not {}", n.len()),
        )),
    }
}

/// A non-negative integer index.
pub fn index(v: &Value, what: &str, len: usize) -> Result<u32, ScadError> {
    let n = number(v, what)?;
    if n < 0.0 || n.fract() != 0.0 || n >= len as f64 {
        return Err(ScadError::new(
            v.pos,
            format!(
                "{what}: {n} is not a point index (an integer from 0 to {})",
                len as i64 - 1
            ),
        ));
    }
    Ok(n as u32)
}
