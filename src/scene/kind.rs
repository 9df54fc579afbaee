//! Which files are scenes (a scene is a TOML file, docs/scene-format.md). A file of
//! another kind gets an error saying so before its text is parsed, rather than a
//! TOML syntax error in the middle of OpenSCAD code.

use std::path::Path;

use super::load::SceneError;

/// What the user can give instead (said once, in every such message).
pub const SUPPORTED: &str =
    "peeltrim reads scenes written in TOML (`.toml`, see docs/scene-format.md) \
     and OpenSCAD's CSG export (`.csg`: in OpenSCAD, File > Export > Export as CSG)";

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
}

/// Refuses at once a file that is known not to be a scene: OpenSCAD sources.
pub fn refuse_unsupported(path: &Path) -> Result<(), SceneError> {
    if extension(path).as_deref() == Some("scad") {
        return Err(SceneError::Unsupported {
            path: path.to_path_buf(),
            message: format!(
                "an OpenSCAD source file is not a scene: {SUPPORTED}; export this model as CSG, or describe it in a .toml scene"
            ),
        });
    }
    Ok(())
}

/// A TOML syntax error in a file not named `.toml` says what the file should be.
pub fn hint(path: &Path, e: SceneError) -> SceneError {
    match (extension(path).as_deref(), e) {
        // `.csg` files are parsed by the OpenSCAD reader, with its own messages.
        (Some("toml" | "csg"), e) => e,
        (
            _,
            SceneError::Syntax {
                path,
                line,
                column,
                message,
                snippet,
            },
        ) => SceneError::Syntax {
            message: format!(
                "{message}\n(this file is not named .toml and is not valid TOML: {SUPPORTED})"
            ),
            path,
            line,
            column,
            snippet,
        },
        (_, e) => e,
    }
}
