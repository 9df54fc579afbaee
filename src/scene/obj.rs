//! Wavefront OBJ for `shape = "mesh"` (docs/scene-format.md): all objects and groups
//! merged into one mesh, polygons fan-triangulated from their first vertex, in file
//! order.
//!
//! Why not `tobj`: it splits objects/groups into models with their own vertex arrays,
//! so a closed mesh whose groups share vertices would come back cracked along the
//! group borders, and welding positions afterwards would merge vertices the file
//! keeps apart. Only `v` and `f` matter for a solid, so this reads them directly:
//! vertex `k` of the mesh is the file's `v` line `k + 1`, and nothing is welded
//! beyond what the file indexes.

use glam::DVec3;
use std::path::Path;

use super::Mesh;

/// Reads an OBJ file. Errors are one line naming the file (and the line in it).
pub fn load_obj(path: &Path) -> Result<Mesh, String> {
    let text = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let text = String::from_utf8_lossy(&text);
    parse_obj(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Parses OBJ text (see [`load_obj`]).
pub fn parse_obj(text: &str) -> Result<Mesh, String> {
    let mut mesh = Mesh::default();
    let mut pending = String::new();
    let mut first_line = 0;
    for (k, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("");
        if pending.is_empty() {
            first_line = k + 1;
        }
        // A trailing backslash continues the statement on the next line.
        if let Some(stripped) = line.trim_end().strip_suffix('\\') {
            pending.push_str(stripped);
            pending.push(' ');
            continue;
        }
        pending.push_str(line);
        let stmt = std::mem::take(&mut pending);
        statement(&stmt, &mut mesh).map_err(|e| format!("line {first_line}: {e}"))?;
    }
    if !pending.is_empty() {
        statement(&pending, &mut mesh).map_err(|e| format!("line {first_line}: {e}"))?;
    }
    if mesh.triangles.is_empty() {
        return Err("no faces (`f` lines) found; a mesh primitive needs triangles".into());
    }
    Ok(mesh)
}

fn statement(stmt: &str, mesh: &mut Mesh) -> Result<(), String> {
    let mut tok = stmt.split_whitespace();
    match tok.next() {
        Some("v") => {
            let mut c = [0.0f64; 3];
            for (i, slot) in c.iter_mut().enumerate() {
                let t = tok
                    .next()
                    .ok_or_else(|| format!("vertex needs 3 coordinates, found {i}"))?;
                *slot = t
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| format!("vertex coordinate `{t}` is not a finite number"))?;
            }
            mesh.positions.push(DVec3::from_array(c));
        }
        Some("f") => {
            let n = mesh.positions.len() as i64;
            let mut idx = Vec::new();
            for t in tok {
                let first = t.split('/').next().unwrap_or("");
                let i: i64 = first
                    .parse()
                    .map_err(|_| format!("face vertex `{t}` has no valid position index"))?;
                // 1-based; negative counts back from the latest vertex.
                let abs = if i < 0 { n + i } else { i - 1 };
                if i == 0 || abs < 0 || abs >= n {
                    return Err(format!(
                        "face vertex `{t}` refers to vertex {i}, but only {n} vertices are defined so far"
                    ));
                }
                idx.push(abs as u32);
            }
            if idx.len() < 3 {
                return Err(format!(
                    "face has {} vertices; at least 3 needed",
                    idx.len()
                ));
            }
            for k in 1..idx.len() - 1 {
                mesh.triangles.push([idx[0], idx[k], idx[k + 1]]);
            }
        }
        // Normals, texture coordinates, groups, objects, materials, smoothing: not
        // part of the solid.
        _ => {}
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fan_triangulation_and_groups_merged() {
        let src = "# quad pyramid\no a\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\ng base\nf 1 2 3 4\n\
                   o b\nv 0.5 1 0.5\nf 1/1/1 5//2 2\nf -4 -1 -3\n";
        let m = parse_obj(src).unwrap();
        assert_eq!(m.positions.len(), 5);
        assert_eq!(
            m.triangles,
            vec![[0, 1, 2], [0, 2, 3], [0, 4, 1], [1, 4, 2]]
        );
    }

    #[test]
    fn errors_name_the_line() {
        assert!(parse_obj("v 0 0 0\nf 1 2 3\n")
            .unwrap_err()
            .starts_with("line 2"));
        assert!(parse_obj("v 0 0\n").unwrap_err().contains("3 coordinates"));
        assert!(parse_obj("v 0 0 0\n").unwrap_err().contains("no faces"));
        assert!(parse_obj("v 0 0 nan\n").unwrap_err().contains("finite"));
        assert!(load_obj(Path::new("/nonexistent/x.obj"))
            .unwrap_err()
            .contains("/nonexistent/x.obj"));
    }
}
