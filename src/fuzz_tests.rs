//! Property-based fuzzing of the parsers a user feeds: scene TOML,
//! CSG expressions and OBJ. Inputs are generated structure-aware (valid
//! documents with hostile values: wrong vector lengths and element types, NaN,
//! infinities, huge counts, unicode, unknown keys and names) and then possibly
//! truncated or spliced with junk. Every case must end in bounded time with
//! success or an error that says where (line, column or key path); an input the
//! generator made definitely malformed must be an error.
//!
//! `PEELTRIM_FUZZ_CASES` multiplies the case counts, `PEELTRIM_FUZZ_CASE_MS`
//! sets the time allowed per case and `PEELTRIM_FUZZ_DUMP=DIR` writes every
//! generated scene there (`tools/fuzz.sh` runs long sessions this way, and feeds
//! the scenes to the binary under an address-space limit).

use std::path::Path;
use std::time::{Duration, Instant};

use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

use crate::scene::{load_str, LoadOptions, SceneError};

/// Memory budget of the fuzzed loads: small, so that huge but legal counts are
/// refused by the budget check quickly instead of being tessellated.
const FUZZ_BUDGET: u64 = 64 << 20;

fn env_u64(key: &str, default: u64) -> u64 {
    std::env::var(key)
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(default)
}

/// A proptest runner of `base_cases` cases, times `PEELTRIM_FUZZ_CASES`.
pub(crate) fn runner(base_cases: u32) -> TestRunner {
    let cases = base_cases as u64 * env_u64("PEELTRIM_FUZZ_CASES", 1).max(1);
    TestRunner::new(Config {
        cases: cases.min(u32::MAX as u64) as u32,
        failure_persistence: None,
        ..Config::default()
    })
}

/// The time one case may take (`PEELTRIM_FUZZ_CASE_MS`, default 2 s).
pub(crate) fn case_limit() -> Duration {
    Duration::from_millis(env_u64("PEELTRIM_FUZZ_CASE_MS", 2000))
}

/// A generated piece of input and whether it is definitely malformed.
#[derive(Clone, Debug)]
struct Gen {
    text: String,
    bad: bool,
}

fn ok(text: impl Into<String>) -> Gen {
    Gen {
        text: text.into(),
        bad: false,
    }
}

fn bad(text: impl Into<String>) -> Gen {
    Gen {
        text: text.into(),
        bad: true,
    }
}

fn join(parts: &[Gen], sep: &str) -> Gen {
    Gen {
        text: parts
            .iter()
            .map(|g| g.text.as_str())
            .collect::<Vec<_>>()
            .join(sep),
        bad: parts.iter().any(|g| g.bad),
    }
}

fn finite() -> impl Strategy<Value = String> {
    prop_oneof![
        (-50i32..50).prop_map(|i| i.to_string()),
        (-20.0f64..20.0).prop_map(|f| format!("{f:?}")),
    ]
}

fn positive() -> impl Strategy<Value = String> {
    prop_oneof![
        (1i32..5).prop_map(|i| i.to_string()),
        (0.05f64..4.0).prop_map(|f| format!("{f:?}")),
    ]
}

/// A value that is not a number (or not a finite one).
fn not_a_number() -> impl Strategy<Value = String> {
    prop::sample::select(vec![
        "\"1.0\"",
        "true",
        "[1.0]",
        "{ x = 1.0 }",
        "1979-05-27",
        "nan",
        "inf",
        "-inf",
        "\"é\"",
        "\"\u{202e}1\"",
    ])
    .prop_map(str::to_string)
}

/// A 3-vector value: valid (components from `comp`), or of a wrong length, with
/// an element of a wrong type, not an array, or not finite.
fn vector(comp: BoxedStrategy<String>) -> BoxedStrategy<Gen> {
    prop_oneof![
        100 => prop::collection::vec(comp.clone(), 3).prop_map(|v| ok(format!("[{}]", v.join(", ")))),
        1 => prop::collection::vec(comp.clone(), 0..7)
            .prop_filter("not 3", |v| v.len() != 3)
            .prop_map(|v| bad(format!("[{}]", v.join(", ")))),
        1 => (prop::collection::vec(comp, 3), 0usize..3, not_a_number()).prop_map(|(mut v, i, x)| {
            v[i] = x;
            bad(format!("[{}]", v.join(", ")))
        }),
        1 => not_a_number().prop_map(bad),
    ]
    .boxed()
}

fn number(valid: BoxedStrategy<String>, invalid: &'static [&'static str]) -> BoxedStrategy<Gen> {
    prop_oneof![
        100 => valid.prop_map(ok),
        1 => prop::sample::select(invalid.to_vec()).prop_map(bad),
        1 => not_a_number().prop_map(bad),
    ]
    .boxed()
}

fn count() -> BoxedStrategy<Gen> {
    prop_oneof![
        100 => (3u32..24).prop_map(|n| ok(n.to_string())),
        // (Not 2: too few segments, but enough rings for a sphere.)
        1 => prop::sample::select(vec!["0", "1", "-3", "65537", "4294967295", "99999999999", "8.5"])
            .prop_map(bad),
        // Legal but huge: the grid limit or the memory budget refuses these.
        1 => prop::sample::select(vec!["65536", "4096", "1000"]).prop_map(ok),
    ]
    .boxed()
}

fn color() -> BoxedStrategy<Gen> {
    prop_oneof![
        100 => "[0-9a-f]{6}".prop_map(|h| ok(format!("\"#{h}\""))),
        1 => prop::sample::select(vec!["\"#12345\"", "\"d0a040\"", "\"#gg0000\"", "[1, 2, 3]", "5", "\"#ｄ0a040\""])
            .prop_map(bad),
    ]
    .boxed()
}

const NAMES: [&str; 4] = ["A", "B", "C", "D"];

/// An expression over `A`–`D` (valid) with its value for every assignment of
/// the four primitives (bit i of the index: inside primitive i).
#[derive(Clone, Debug)]
struct ExprGen {
    text: String,
    truth: u16,
}

fn expr_tree() -> impl Strategy<Value = ExprGen> {
    let leaf = (0usize..4).prop_map(|i| {
        let truth = (0..16u16).fold(0, |t, a| t | ((((a >> i) & 1) as u16) << a));
        ExprGen {
            text: NAMES[i].to_string(),
            truth,
        }
    });
    leaf.prop_recursive(6, 48, 2, |inner| {
        prop_oneof![
            4 => (inner.clone(), inner.clone(), 0usize..4, any::<bool>()).prop_map(|(a, b, op, spaced)| {
                let s = if spaced { " " } else { "" };
                let (text, truth) = match op {
                    0 => (format!("({}{s}+{s}{})", a.text, b.text), a.truth | b.truth),
                    1 => (format!("({}{s}-{s}{})", a.text, b.text), a.truth & !b.truth),
                    2 => (format!("({}{s}*{s}{})", a.text, b.text), a.truth & b.truth),
                    _ => (format!("({} {})", a.text, b.text), a.truth & b.truth),
                };
                ExprGen { text, truth }
            }),
            1 => inner.prop_map(|a| ExprGen {
                text: format!("!{}", a.text),
                truth: !a.truth,
            }),
        ]
    })
}

/// An expression source: a valid one, or one made definitely malformed.
fn expr_source() -> BoxedStrategy<(Gen, Option<u16>)> {
    prop_oneof![
        12 => expr_tree().prop_map(|e| (ok(e.text), Some(e.truth))),
        1 => (expr_tree(), prop::sample::select(vec![" + Q", " +", ")", " (", " * é", " & B", " - "]))
            .prop_map(|(e, junk)| (bad(format!("{}{junk}", e.text)), None)),
        1 => (expr_tree(), any::<prop::sample::Index>()).prop_map(|(e, i)| {
            // Drop one character: an unbalanced or dangling expression, or still valid.
            let chars: Vec<char> = e.text.chars().collect();
            let k = i.index(chars.len());
            (ok(chars.iter().enumerate().filter(|&(j, _)| j != k).map(|(_, c)| c).collect::<String>()), None)
        }),
        1 => prop::sample::select(vec!["", "   ", "()", "!", "A B C D E", "((((", "))))", "A--B", "Ω"])
            .prop_map(|s| (if s == "A B C D E" { bad(s) } else { ok(s) }, None)),
    ]
    .boxed()
}

fn shape_table(table: &'static str, name: &'static str) -> BoxedStrategy<Gen> {
    let shape = prop_oneof![
        24 => Just(("box", false)),
        12 => Just(("sphere", false)),
        8 => Just(("cylinder", false)),
        4 => Just(("cone", false)),
        8 => Just(("torus", false)),
        1 => Just(("blob", true)),
        1 => Just(("mesh", true)),
    ];
    let extra = prop_oneof![
        150 => Just(ok("")),
        1 => prop::sample::select(vec!["colour = \"#ffffff\"", "size = [1.0, 1.0, 1.0]\nsize = [2.0, 2.0, 2.0]", "\"\u{1F600}\" = 1"])
            .prop_map(|s| bad(format!("{s}\n"))),
    ];
    (
        shape,
        vector(positive().boxed()),
        number(positive().boxed(), &["0", "-1.0", "0.0"]),
        count(),
        prop::option::of(count()),
        prop::option::of(vector(finite().boxed())),
        prop::option::of(vector(finite().boxed())),
        prop::option::of(prop_oneof![
            positive().prop_map(ok),
            vector(positive().boxed())
        ]),
        prop::option::of(color()),
        extra,
    )
        .prop_map(
            move |(shape, size, radius, segments, rings, rot, tr, scale, color, extra)| {
                let (kind, shape_bad) = shape;
                let mut parts = vec![
                    ok(format!(
                        "[[{table}]]\nname = \"{name}\"\nshape = \"{kind}\"\n"
                    )),
                    Gen {
                        text: String::new(),
                        bad: shape_bad,
                    },
                ];
                let mut key = |k: &str, g: Gen| {
                    parts.push(Gen {
                        text: format!("{k} = {}\n", g.text),
                        bad: g.bad,
                    })
                };
                match kind {
                    "box" => key("size", size),
                    "sphere" | "torus" => {
                        if kind == "torus" {
                            // minor < major is checked; keep that valid here.
                            key("radius", ok("4.5"));
                            let minor = match radius.text.parse::<f64>() {
                                Ok(r) if !radius.bad && r >= 4.5 => bad(radius.text),
                                _ => radius,
                            };
                            key("minor_radius", minor);
                        } else {
                            key("radius", radius);
                        }
                        key("segments", segments);
                        if let Some(r) = rings {
                            key("rings", r);
                        }
                    }
                    "cylinder" | "cone" => {
                        key("radius", radius);
                        key("height", ok("1.0"));
                        key("segments", segments);
                    }
                    "mesh" => key("path", ok("\"does/not/exist.obj\"")),
                    _ => key("size", size),
                }
                if let Some(v) = rot {
                    key("rotate_deg", v);
                }
                if let Some(v) = tr {
                    key("translate", v);
                }
                if let Some(v) = scale {
                    key("scale", v);
                }
                if let Some(v) = color {
                    key("color", v);
                }
                if table == "surface" {
                    key("trim", ok("\"A\""));
                }
                let mut g = join(&parts, "");
                g.text.push_str(&extra.text);
                g.bad |= extra.bad;
                g
            },
        )
        .boxed()
}

fn camera() -> BoxedStrategy<Gen> {
    prop_oneof![
        1 => Just(ok("")),
        4 => (
            vector(finite().boxed()),
            prop::option::of(vector(finite().boxed())),
            prop::option::of(vector(finite().boxed())),
            prop::option::of(number(
                (1u32..170).prop_map(|d| d.to_string()).boxed(),
                &["0", "180", "-5", "1e9"]
            )),
            any::<bool>(),
        )
            .prop_map(|(eye, target, up, fov, fit)| {
                let mut parts = vec![ok("[camera]\n"), ok(format!("eye = {}\n", eye.text))];
                parts[1].bad = eye.bad;
                for (k, v) in [("target", target), ("up", up), ("fov_y_deg", fov)] {
                    if let Some(v) = v {
                        parts.push(Gen {
                            text: format!("{k} = {}\n", v.text),
                            bad: v.bad,
                        });
                    }
                }
                parts.push(ok(format!("fit = {fit}\n")));
                join(&parts, "")
            }),
    ]
    .boxed()
}

/// A whole scene file, then possibly truncated or spliced with junk (which makes
/// its validity unknown).
fn scene() -> BoxedStrategy<Gen> {
    let body = (
        camera(),
        0usize..8,
        prop::option::of(shape_table("surface", "S")),
        expr_source(),
        prop::option::of((
            number(
                (1u32..64).prop_map(|n| n.to_string()).boxed(),
                &["0", "16385", "-1", "4294967296"],
            ),
            prop::option::of(color()),
        )),
    )
        .prop_flat_map(|(cam, prims, surface, (expr, _), render)| {
            // Usually all of A-D are defined; fewer make the names past them unknown.
            let n = if prims < 2 { prims + 2 } else { 4 };
            let tables: Vec<BoxedStrategy<Gen>> = NAMES[..n]
                .iter()
                .map(|name| shape_table("primitive", name))
                .collect();
            (tables, Just((cam, surface, expr, render)))
        })
        .prop_map(|(tables, (cam, surface, expr, render))| {
            let n = tables.len();
            let mut parts = vec![cam];
            parts.extend(tables);
            if let Some(s) = surface {
                parts.push(s);
            }
            if let Some((w, bg)) = render {
                parts.push(Gen {
                    text: format!("[render]\nwidth = {}\nheight = 16\n", w.text),
                    bad: w.bad,
                });
                if let Some(bg) = bg {
                    parts.push(Gen {
                        text: format!("background = {}\n", bg.text),
                        bad: bg.bad,
                    });
                }
            }
            // Names past the defined primitives are unknown: malformed.
            let unknown = NAMES[n..].iter().any(|name| expr.text.contains(name));
            parts.push(Gen {
                text: format!("[csg]\nexpr = \"{}\"\n", expr.text),
                bad: expr.bad || unknown,
            });
            join(&parts, "")
        });
    (
        body,
        0u8..10,
        any::<prop::sample::Index>(),
        "[\\PC\\x00\\x7f\"=#\\[\\]]{0,4}",
    )
        .prop_map(|(g, mutation, at, junk)| {
            let chars: Vec<char> = g.text.chars().collect();
            let k = at.index(chars.len().max(1)).min(chars.len());
            match mutation {
                // Truncated file.
                0 => Gen {
                    text: chars[..k].iter().collect(),
                    bad: false,
                },
                // Junk spliced in.
                1 => Gen {
                    text: chars[..k]
                        .iter()
                        .chain(junk.chars().collect::<Vec<_>>().iter())
                        .chain(chars[k..].iter())
                        .collect(),
                    bad: false,
                },
                _ => g,
            }
        })
        .boxed()
}

/// Whether a scene error says where: TOML line and column, or a key path.
fn located(e: &SceneError) -> bool {
    match e {
        SceneError::Syntax { line, column, .. } => *line >= 1 && *column >= 1,
        SceneError::Invalid { key, .. } => !key.trim().is_empty(),
        SceneError::Read { .. } | SceneError::Unsupported { .. } => true,
    }
}

#[test]
fn fuzz_scene_files() {
    let path = Path::new("/fuzz/scene.toml");
    let limit = case_limit();
    // `tools/fuzz.sh` also feeds the generated scenes to the binary.
    let dump = std::env::var_os("PEELTRIM_FUZZ_DUMP").map(std::path::PathBuf::from);
    let counter = std::sync::atomic::AtomicUsize::new(0);
    let (accepted, refused) = (std::cell::Cell::new(0u32), std::cell::Cell::new(0u32));
    runner(5000)
        .run(&scene(), |g| {
            if let Some(dir) = &dump {
                let k = counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let _ = std::fs::write(
                    dir.join(format!(
                        "case-{k:06}{}.toml",
                        if g.bad { "-bad" } else { "" }
                    )),
                    &g.text,
                );
            }
            let t = Instant::now();
            let r = crate::budget::with(FUZZ_BUDGET, || {
                load_str(&g.text, path, &LoadOptions::default())
            });
            let took = t.elapsed();
            prop_assert!(took < limit, "took {took:?}:\n{}", g.text);
            match r {
                Ok(s) => {
                    accepted.set(accepted.get() + 1);
                    prop_assert!(!g.bad, "accepted a malformed scene:\n{}", g.text);
                    let persp = matches!(
                        s.camera.projection,
                        crate::scene::Projection::Perspective { .. }
                    );
                    prop_assert!(s.camera.near > 0.0 || !persp, "near {}", s.camera.near);
                    prop_assert!(s.camera.near < s.camera.far && s.camera.far.is_finite());
                }
                Err(e) => {
                    refused.set(refused.get() + 1);
                    if std::env::var_os("PEELTRIM_FUZZ_SHOW").is_some() && !g.bad {
                        eprintln!("{e}");
                    }
                    prop_assert!(located(&e), "no location: {e}\n{}", g.text);
                    let msg = e.to_string();
                    prop_assert!(msg.starts_with("/fuzz/scene.toml:"), "{msg}");
                }
            }
            Ok(())
        })
        .unwrap();
    // The generator must reach both outcomes in earnest, or the test proves little.
    let (a, r) = (accepted.get(), refused.get());
    eprintln!("fuzz_scene_files: {a} accepted, {r} refused");
    assert!(
        a * 10 > a + r && r * 10 > a + r,
        "{a} accepted, {r} refused"
    );
}

#[test]
fn fuzz_expressions() {
    let limit = case_limit();
    let names = |n: &str| NAMES.iter().position(|x| *x == n).map(|i| i as u32);
    runner(4000)
        .run(&expr_source(), |(g, truth)| {
            let t = Instant::now();
            let r = crate::csg::parse(&g.text, &mut |n| names(n));
            prop_assert!(t.elapsed() < limit);
            match r {
                Ok(e) => {
                    prop_assert!(!g.bad, "accepted {:?}", g.text);
                    if let Some(truth) = truth {
                        // The algebra against the tree: every assignment of A-D.
                        let pos = crate::csg::PositiveExpr::from_expr(&e);
                        for a in 0..16u16 {
                            let got = pos.eval(|l| (a >> l.prim) & 1 == 1);
                            prop_assert_eq!(got, (truth >> a) & 1 == 1, "{} at {:04b}", g.text, a);
                        }
                    }
                }
                Err(e) => {
                    let len = g.text.chars().count();
                    prop_assert!(
                        e.column >= 1 && e.column <= len + 1,
                        "column {} of {:?}",
                        e.column,
                        g.text
                    );
                    prop_assert!(e.to_string().contains("hint: "));
                }
            }
            Ok(())
        })
        .unwrap();
}

fn obj_text() -> BoxedStrategy<Gen> {
    let vline = prop_oneof![
        6 => prop::collection::vec(finite(), 3).prop_map(|c| ok(format!("v {}", c.join(" ")))),
        1 => prop::collection::vec(finite(), 4).prop_map(|c| ok(format!("v {}", c.join(" ")))),
        1 => prop::collection::vec(finite(), 0..3).prop_map(|c| bad(format!("v {}", c.join(" ")))),
        1 => not_a_number().prop_map(|x| bad(format!("v 0 {x} 0"))),
    ];
    let fline = prop_oneof![
        6 => prop::collection::vec(1i64..6, 3..6).prop_map(|i| {
            // Indices up to 5 exist when at least 5 vertices come first (below).
            ok(format!("f {}", i.iter().map(|x| format!("{x}/1/{x}")).collect::<Vec<_>>().join(" ")))
        }),
        1 => prop::collection::vec(-5i64..0, 3).prop_map(|i| ok(format!("f {}", i.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" ")))),
        1 => prop::sample::select(vec!["f 0 1 2", "f 1 2 99999999999", "f a b c", "f 1 2 -1000"]).prop_map(bad),
        1 => prop::sample::select(vec!["f 1 2", "f", "# comment", "o part", "g group", "vn 0 0 1", "s off", "f 1 2 \\", "\u{feff}v 0 0 0", "mtllib x.mtl"])
            .prop_map(ok),
    ];
    (
        prop::collection::vec(vline, 0..6),
        prop::collection::vec(fline, 0..8),
        0u8..8,
        any::<prop::sample::Index>(),
    )
        .prop_map(|(vs, fs, mutation, at)| {
            let mut lines: Vec<Gen> = (0..5).map(|i| ok(format!("v {i} {} 0", i * i))).collect();
            lines.extend(vs);
            lines.extend(fs);
            let g = join(&lines, "\n");
            if mutation == 0 {
                let chars: Vec<char> = g.text.chars().collect();
                let k = at.index(chars.len().max(1)).min(chars.len());
                ok(chars[..k].iter().collect::<String>())
            } else {
                g
            }
        })
        .boxed()
}

#[test]
fn fuzz_obj() {
    let limit = case_limit();
    runner(3000)
        .run(&obj_text(), |g| {
            let t = Instant::now();
            let r = crate::scene::obj::parse_obj(&g.text);
            prop_assert!(t.elapsed() < limit);
            match r {
                Ok(m) => {
                    prop_assert!(!g.bad, "accepted a malformed OBJ:\n{}", g.text);
                    let n = m.positions.len() as u32;
                    prop_assert!(m.triangles.iter().flatten().all(|&i| i < n));
                    prop_assert!(m.positions.iter().all(|p| p.is_finite()));
                }
                Err(e) => {
                    prop_assert!(
                        e.starts_with("line ") || e.starts_with("no faces"),
                        "no location: {e}"
                    );
                }
            }
            Ok(())
        })
        .unwrap();
}
