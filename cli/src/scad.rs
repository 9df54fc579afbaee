//! OpenSCAD source files (`.scad`): exported to OpenSCAD's CSG by the
//! `openscad` program, into a cache keyed by the file's content, and read from
//! there like any `.csg` file.
//!
//! - The cache is `$PEELTRIM_CACHE_DIR/scad`, else `$XDG_CACHE_HOME/peeltrim/scad`,
//!   else `~/.cache/peeltrim/scad`, else the temporary folder's
//!   `peeltrim-cache/scad`. A file is `<stem>-<key>.csg`, `key` the 64-bit
//!   FNV-1a hash of the source's bytes and of its folder (so relative imports
//!   resolve alike); an edited file is exported again, an unchanged one is not.
//!   Files the model `include`s or `use`s are not part of the key: after
//!   editing only those, touch the model, or delete the cache folder.
//! - The program is `$PEELTRIM_OPENSCAD`, else `openscad` on the `PATH`.
//! - OpenSCAD writes `import` and `surface` paths as the source gave them,
//!   relative to the `.scad` file's folder; the cached copy has them made
//!   absolute, so they resolve from the cache.

use std::path::{Path, PathBuf};
use std::process::Command;

/// How to get a `.csg` without the conversion (said in every error).
const INSTEAD: &str =
    "or export the model from OpenSCAD (File > Export > Export as CSG) and pass the .csg file";

/// `path` itself, or for a `.scad` file the cached `.csg` export of it.
pub fn csg_for(path: &Path) -> Result<PathBuf, String> {
    if !is_scad(path) {
        return Ok(path.to_path_buf());
    }
    let bytes = std::fs::read(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    let key = fnv1a(&[&bytes, dir.as_os_str().as_encoded_bytes()]);
    let stem = path
        .file_stem()
        .map_or("model".into(), |s| s.to_string_lossy());
    let cache = cache_dir();
    let out = cache.join(format!("{stem}-{key:016x}.csg"));
    if out.is_file() {
        return Ok(out);
    }
    std::fs::create_dir_all(&cache).map_err(|e| {
        format!(
            "{}: cannot create the cache folder {} for its CSG export: {e} (set PEELTRIM_CACHE_DIR to a writable folder)",
            path.display(),
            cache.display()
        )
    })?;
    let tmp = cache.join(format!("{stem}-{key:016x}.{}.tmp.csg", std::process::id()));
    export(path, &tmp)?;
    let text = std::fs::read_to_string(&tmp).map_err(|e| {
        format!(
            "{}: cannot read openscad's export {}: {e}",
            path.display(),
            tmp.display()
        )
    })?;
    let _ = std::fs::remove_file(&tmp);
    std::fs::write(&tmp, absolute_files(&text, &dir))
        .and_then(|()| std::fs::rename(&tmp, &out))
        .map_err(|e| format!("{}: cannot write {}: {e}", path.display(), out.display()))?;
    Ok(out)
}

/// Runs `openscad -o csg scad`, without the cache.
pub fn export(scad: &Path, csg: &Path) -> Result<(), String> {
    let program = std::env::var_os("PEELTRIM_OPENSCAD").unwrap_or_else(|| "openscad".into());
    let run = Command::new(&program).arg("-o").arg(csg).arg(scad).output();
    let out = match run {
        Ok(o) => o,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(format!(
                "{}: an OpenSCAD source file, which peeltrim reads by running `openscad -o model.csg model.scad`, but `{}` is not installed: install OpenSCAD (Debian and Ubuntu: `apt-get install openscad`; in this repository: `tools/setup.sh --openscad`), {INSTEAD}",
                scad.display(),
                program.to_string_lossy()
            ))
        }
        Err(e) => {
            return Err(format!(
                "{}: cannot run `{}`: {e}; {INSTEAD}",
                scad.display(),
                program.to_string_lossy()
            ))
        }
    };
    if !out.status.success() || !csg.is_file() {
        let _ = std::fs::remove_file(csg);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = stderr
            .lines()
            .filter(|l| !l.trim().is_empty())
            .rev()
            .take(8)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        return Err(format!(
            "{}: openscad could not export the model ({}):\n{}\nfix the model in OpenSCAD, {INSTEAD}",
            scad.display(),
            out.status,
            tail.join("\n")
        ));
    }
    Ok(())
}

/// Whether `path` names an OpenSCAD source file.
pub fn is_scad(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("scad"))
}

fn cache_dir() -> PathBuf {
    let var = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if let Some(d) = var("PEELTRIM_CACHE_DIR") {
        return d.join("scad");
    }
    if let Some(d) = var("XDG_CACHE_HOME") {
        return d.join("peeltrim").join("scad");
    }
    if let Some(h) = var("HOME") {
        return h.join(".cache").join("peeltrim").join("scad");
    }
    std::env::temp_dir().join("peeltrim-cache").join("scad")
}

/// FNV-1a, 64 bits, over the parts in order (a stable key across builds).
fn fnv1a(parts: &[&[u8]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in parts {
        for &b in *part {
            h ^= b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        h ^= 0xff;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// `file = "x"` of `import` and `surface` made absolute against `dir`.
fn absolute_files(text: &str, dir: &Path) -> String {
    const KEY: &str = "file = \"";
    let mut out = String::with_capacity(text.len());
    for line in text.split_inclusive('\n') {
        let t = line.trim_start().trim_start_matches(['%', '#', '!', '*']);
        let (Some(start), true) = (
            line.find(KEY),
            t.starts_with("import(") || t.starts_with("surface("),
        ) else {
            out.push_str(line);
            continue;
        };
        let s = start + KEY.len();
        // The string ends at the first quote not escaped.
        let mut end = None;
        let mut esc = false;
        for (k, c) in line[s..].char_indices() {
            match (esc, c) {
                (true, _) => esc = false,
                (false, '\\') => esc = true,
                (false, '"') => {
                    end = Some(s + k);
                    break;
                }
                _ => {}
            }
        }
        let Some(end) = end else {
            out.push_str(line);
            continue;
        };
        let file = line[s..end].replace("\\\"", "\"").replace("\\\\", "\\");
        if Path::new(&file).is_absolute() {
            out.push_str(line);
            continue;
        }
        let abs = dir
            .join(&file)
            .to_string_lossy()
            .replace('\\', "\\\\")
            .replace('"', "\\\"");
        out.push_str(&line[..s]);
        out.push_str(&abs);
        out.push_str(&line[end..]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn import_and_surface_paths_become_absolute() {
        let csg = "import(file = \"a.stl\", layer = \"\");\n%surface(file = \"sub/h.dat\", center = true);\nimport(file = \"/abs/b.off\");\ncube();\n";
        let out = absolute_files(csg, Path::new("/models"));
        assert_eq!(
            out,
            "import(file = \"/models/a.stl\", layer = \"\");\n%surface(file = \"/models/sub/h.dat\", center = true);\nimport(file = \"/abs/b.off\");\ncube();\n"
        );
    }

    #[test]
    fn keys_differ_by_content_and_folder() {
        assert_ne!(fnv1a(&[b"cube();", b"/a"]), fnv1a(&[b"cube(); ", b"/a"]));
        assert_ne!(fnv1a(&[b"cube();", b"/a"]), fnv1a(&[b"cube();", b"/b"]));
        assert_eq!(fnv1a(&[b"x", b"/a"]), fnv1a(&[b"x", b"/a"]));
    }
}
