//! Compiles every `shaders/*.vert` and `shaders/*.frag` (GLSL 450) to SPIR-V with
//! naga into `OUT_DIR/<name>.<stage>.spv`. A shader that fails to compile is a bug
//! of this crate, so the build panics with the file name and naga's message.
//! A line `#include "x.glsl"` is replaced by `shaders/x.glsl` (naga's GLSL front
//! end has no includes), so shared shader code is written once. A shader that
//! mentions `#ifdef NORMALS` is also compiled with `NORMALS` defined, into
//! `OUT_DIR/<name>.<stage>.normals.spv`: the variant that writes the normal buffer
//! (Kirsch, Nienhaus & Döllner §5.2) for executors that ask for one. Likewise
//! `#ifdef HOST` gives `<name>.<stage>.host.spv`: the variant drawing into an
//! embedding host's attachments (`vk::exec::record::host`), and `#ifdef HOST_SRGB`
//! gives `<name>.<stage>.host_srgb.spv` (`HOST` and `HOST_SRGB` defined): the variant
//! for an `_SRGB` host colour format, which decodes the colour it writes;
//! `#ifdef HOST_WRITE` gives `host_write` and `host_write_srgb` (the host draw
//! that writes its depth, with no merge before it), and `#ifdef FLAT` gives
//! `flat` (`mesh.vert` without the interpolated outputs), and `#ifdef MS`
//! gives `ms` (the depth texture multisampled, read at the invocation's own
//! sample: `shaders/depth_tex.glsl`), with the host variants as `host_ms`,
//! `host_srgb_ms`, `host_write_ms` and `host_write_srgb_ms` (the embedded
//! final shade into a multisampled host frame). A
//! variant rather than a push-constant branch because lavapipe runs both sides
//! of a uniform branch for every fragment.

use std::path::Path;

fn main() {
    let out_dir = std::env::var("OUT_DIR").expect("OUT_DIR is set by cargo");
    let shader_dir = Path::new("shaders");
    println!("cargo:rerun-if-changed=shaders");
    let mut entries: Vec<_> = std::fs::read_dir(shader_dir)
        .expect("shaders/ exists")
        .map(|e| e.expect("readable shaders/ entry").path())
        .collect();
    entries.sort();
    for path in entries {
        let stage = match path.extension().and_then(|e| e.to_str()) {
            Some("vert") => naga::ShaderStage::Vertex,
            Some("frag") => naga::ShaderStage::Fragment,
            _ => continue,
        };
        println!("cargo:rerun-if-changed={}", path.display());
        let source = with_includes(shader_dir, &path);
        let name = path.file_name().expect("file name").to_string_lossy();
        compile(
            &path,
            stage,
            &source,
            &[],
            &Path::new(&out_dir).join(format!("{name}.spv")),
        );
        // (defines, suffix): compiled when the source tests each define the
        // variant adds to a leading `HOST` (`composite.frag` tests only `HOST_SRGB`).
        let variants: [(&[&str], &str); 11] = [
            (&["MS"], "ms"),
            (&["HOST", "MS"], "host_ms"),
            (&["HOST", "HOST_SRGB", "MS"], "host_srgb_ms"),
            (&["HOST", "HOST_WRITE", "MS"], "host_write_ms"),
            (
                &["HOST", "HOST_WRITE", "HOST_SRGB", "MS"],
                "host_write_srgb_ms",
            ),
            (&["NORMALS"], "normals"),
            (&["FLAT"], "flat"),
            (&["HOST"], "host"),
            (&["HOST", "HOST_SRGB"], "host_srgb"),
            (&["HOST", "HOST_WRITE"], "host_write"),
            (&["HOST", "HOST_WRITE", "HOST_SRGB"], "host_write_srgb"),
        ];
        for (defines, suffix) in variants {
            let tests = |d: &&str| source.lines().any(|l| l.trim() == format!("#ifdef {d}"));
            // A multisampled variant needs every define tested (a host
            // program that samples a depth texture).
            let ms = defines.contains(&"MS");
            let added = &defines[usize::from(defines.len() > 1 && !ms)..];
            if added.iter().all(tests) {
                let out = Path::new(&out_dir).join(format!("{name}.{suffix}.spv"));
                compile(&path, stage, &source, defines, &out);
            }
        }
    }
}

/// Compiles one shader (with each of `defines` defined as 1) into `out`.
fn compile(path: &Path, stage: naga::ShaderStage, source: &str, defines: &[&str], out: &Path) {
    let mut opts = naga::front::glsl::Options::from(stage);
    for d in defines {
        opts.defines.insert(d.to_string(), "1".to_string());
    }
    let module = naga::front::glsl::Frontend::default()
        .parse(&opts, source)
        .unwrap_or_else(|e| {
            panic!(
                "{}: GLSL parse error:\n{}",
                path.display(),
                e.emit_to_string(source)
            )
        });
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .unwrap_or_else(|e| {
        panic!(
            "{}: naga validation error:\n{}",
            path.display(),
            e.emit_to_string(source)
        )
    });
    let options = naga::back::spv::Options {
        lang_version: (1, 3),
        // The projection already maps clip y downwards (Vulkan); no flips,
        // no clamps: depth-equal passes rely on exact, untouched values.
        flags: naga::back::spv::WriterFlags::LABEL_VARYINGS,
        // Use the GLSL set and binding decorations as written.
        fake_missing_bindings: true,
        ..Default::default()
    };
    let words = naga::back::spv::write_vec(&module, &info, &options, None)
        .unwrap_or_else(|e| panic!("{}: SPIR-V generation error: {e}", path.display()));
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    std::fs::write(out, bytes).unwrap_or_else(|e| panic!("cannot write {}: {e}", out.display()));
}

/// The shader's text with each `#include "name"` line replaced by `dir/name`,
/// its own includes replaced in turn.
fn with_includes(dir: &Path, path: &Path) -> String {
    let read = |p: &Path| {
        std::fs::read_to_string(p).unwrap_or_else(|e| panic!("cannot read {}: {e}", p.display()))
    };
    read(path)
        .lines()
        .map(|line| match line.trim().strip_prefix("#include ") {
            Some(name) => {
                let file = dir.join(name.trim().trim_matches('"'));
                println!("cargo:rerun-if-changed={}", file.display());
                // An include may include others (`tie.glsl`: `tie_band.glsl`).
                with_includes(dir, &file)
            }
            None => line.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}
