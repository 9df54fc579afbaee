//! The `.csg` syntax tree: node calls `name(args)` followed by `;`, a `{ ... }`
//! block, or a single child statement, each with optional modifiers `% # ! *`.
//!
//! Both the statement parser and the value parser are iterative (explicit
//! stacks), so nesting depth costs heap, not call stack: a file nested 10^5 deep
//! parses. Nodes live in an arena in pre-order, so a parent's index is always
//! smaller than its children's (the converter relies on that).

use super::lex::{lex, Tok};
use super::{Pos, ScadError};

/// Deepest vector nesting accepted in an argument value (OpenSCAD's export never
/// nests deeper than 3: a matrix or a list of points).
pub const MAX_VALUE_DEPTH: usize = 32;

#[derive(Clone, Debug, PartialEq)]
pub enum ValueKind {
    Number(f64),
    Bool(bool),
    Undef,
    Str(String),
    Vector(Vec<Value>),
}

/// An argument value and where it starts.
#[derive(Clone, Debug, PartialEq)]
pub struct Value {
    pub kind: ValueKind,
    pub pos: Pos,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Arg {
    /// `None` for a positional argument.
    pub name: Option<String>,
    pub value: Value,
    pub pos: Pos,
}

/// The modifier characters in front of a node.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Modifiers {
    /// `%`
    pub background: bool,
    /// `#`
    pub highlight: bool,
    /// `!`
    pub root: bool,
    /// `*`
    pub disabled: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    pub name: String,
    /// Position of the node's name.
    pub pos: Pos,
    pub modifiers: Modifiers,
    pub args: Vec<Arg>,
    /// Arena indices, all larger than this node's.
    pub children: Vec<u32>,
}

/// A parsed file: the top-level statements are `roots`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tree {
    pub nodes: Vec<Node>,
    pub roots: Vec<u32>,
}

/// Where the next statement's node goes.
enum Frame {
    /// Inside `{ ... }` of node `parent` (opened at `open`).
    Block { parent: u32, open: Pos },
    /// `name(args) child`: exactly one statement follows.
    Single { parent: u32 },
}

pub fn parse(text: &str) -> Result<Tree, ScadError> {
    let (toks, eof) = lex(text)?;
    let mut p = Parser { toks, i: 0, eof };
    let mut tree = Tree::default();
    let mut frames: Vec<Frame> = Vec::new();
    loop {
        let Some((tok, pos)) = p.next() else {
            return match frames.iter().rev().find_map(|f| match f {
                Frame::Block { open, .. } => Some(*open),
                Frame::Single { .. } => None,
            }) {
                Some(open) => Err(ScadError::new(
                    open,
                    "this `{` is never closed: add the matching `}`",
                )),
                None if !frames.is_empty() => Err(ScadError::new(
                    eof,
                    "the file ends where a child statement was expected: end the node with `;`",
                )),
                None => Ok(tree),
            };
        };
        let finished = match tok {
            Tok::Punct(';') => matches!(frames.last(), Some(Frame::Single { .. })),
            Tok::Punct('}') => match frames.pop() {
                Some(Frame::Block { .. }) => true,
                _ => {
                    return Err(ScadError::new(
                        pos,
                        "unmatched `}`: remove it, or add the `{` it closes",
                    ))
                }
            },
            Tok::Punct('%' | '#' | '!' | '*') | Tok::Ident(_) => {
                p.i -= 1;
                let node = p.node()?;
                let id = tree.nodes.len() as u32;
                match frames.last() {
                    Some(Frame::Block { parent, .. } | Frame::Single { parent }) => {
                        tree.nodes[*parent as usize].children.push(id)
                    }
                    None => tree.roots.push(id),
                }
                tree.nodes.push(node);
                match p.next() {
                    Some((Tok::Punct(';'), _)) => true,
                    Some((Tok::Punct('{'), open)) => {
                        frames.push(Frame::Block { parent: id, open });
                        false
                    }
                    Some(_) => {
                        p.i -= 1;
                        frames.push(Frame::Single { parent: id });
                        false
                    }
                    None => {
                        return Err(ScadError::new(
                            eof,
                            "the file ends after a node call: end it with `;` or give its children in `{ ... }`",
                        ))
                    }
                }
            }
            _ => {
                return Err(ScadError::new(
                    pos,
                    format!(
                    "expected a node such as `cube(...)`, `group() {{ ... }}` or `}}`, found {}",
                    describe(&tok)
                ),
                ))
            }
        };
        // A finished statement completes every enclosing single-child node.
        if finished {
            while let Some(Frame::Single { .. }) = frames.last() {
                frames.pop();
            }
        }
    }
}

fn describe(t: &Tok) -> String {
    match t {
        Tok::Ident(s) => format!("`{s}`"),
        Tok::Number(n) => format!("the number {n}"),
        Tok::Str(s) => format!("the string {s:?}"),
        Tok::Punct(c) => format!("`{c}`"),
    }
}

struct Parser {
    toks: Vec<(Tok, Pos)>,
    i: usize,
    eof: Pos,
}

impl Parser {
    fn next(&mut self) -> Option<(Tok, Pos)> {
        let t = self.toks.get(self.i).cloned();
        if t.is_some() {
            self.i += 1;
        }
        t
    }

    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.i).map(|(t, _)| t)
    }

    fn expect(&mut self, c: char, what: &str) -> Result<Pos, ScadError> {
        match self.next() {
            Some((Tok::Punct(d), pos)) if d == c => Ok(pos),
            Some((t, pos)) => Err(ScadError::new(
                pos,
                format!("expected `{c}` {what}, found {}", describe(&t)),
            )),
            None => Err(ScadError::new(
                self.eof,
                format!("the file ends where `{c}` was expected {what}"),
            )),
        }
    }

    /// `modifiers name ( args )`
    fn node(&mut self) -> Result<Node, ScadError> {
        let mut modifiers = Modifiers::default();
        let (name, pos) = loop {
            match self.next() {
                Some((Tok::Punct('%'), _)) => modifiers.background = true,
                Some((Tok::Punct('#'), _)) => modifiers.highlight = true,
                Some((Tok::Punct('!'), _)) => modifiers.root = true,
                Some((Tok::Punct('*'), _)) => modifiers.disabled = true,
                Some((Tok::Ident(n), pos)) => break (n, pos),
                Some((t, pos)) => {
                    return Err(ScadError::new(
                        pos,
                        format!(
                            "expected a node name after the modifier, found {}",
                            describe(&t)
                        ),
                    ))
                }
                None => {
                    return Err(ScadError::new(
                        self.eof,
                        "the file ends after a modifier: a node name must follow it",
                    ))
                }
            }
        };
        self.expect(
            '(',
            &format!("after `{name}` (a node call is `{name}(...)`)"),
        )?;
        let mut args = Vec::new();
        if self.peek() == Some(&Tok::Punct(')')) {
            self.i += 1;
        } else {
            loop {
                let apos = self.toks.get(self.i).map_or(self.eof, |t| t.1);
                let arg_name = match (self.toks.get(self.i), self.toks.get(self.i + 1)) {
                    (Some((Tok::Ident(n), _)), Some((Tok::Punct('='), _))) => {
                        let n = n.clone();
                        self.i += 2;
                        Some(n)
                    }
                    _ => None,
                };
                let value = self.value()?;
                args.push(Arg {
                    name: arg_name,
                    value,
                    pos: apos,
                });
                match self.next() {
                    Some((Tok::Punct(','), _)) if self.peek() == Some(&Tok::Punct(')')) => {
                        self.i += 1;
                        break;
                    }
                    Some((Tok::Punct(','), _)) => {}
                    Some((Tok::Punct(')'), _)) => break,
                    Some((t, pos)) => {
                        return Err(ScadError::new(
                            pos,
                            format!(
                                "expected `,` or `)` in the arguments of `{name}`, found {}",
                                describe(&t)
                            ),
                        ))
                    }
                    None => {
                        return Err(ScadError::new(
                            self.eof,
                            format!(
                            "the file ends inside the arguments of `{name}`: close them with `)`"
                        ),
                        ))
                    }
                }
            }
        }
        Ok(Node {
            name,
            pos,
            modifiers,
            args,
            children: Vec::new(),
        })
    }

    /// A value: number (with an optional `-`), `true`/`false`/`undef`/`inf`/`nan`,
    /// a string, or a vector `[v, ...]`; iterative over vector nesting.
    fn value(&mut self) -> Result<Value, ScadError> {
        // Open vectors: (start position, items so far).
        let mut open: Vec<(Pos, Vec<Value>)> = Vec::new();
        loop {
            let (tok, pos) = self.next().ok_or_else(|| {
                ScadError::new(self.eof, "the file ends where a value was expected")
            })?;
            let scalar = match tok {
                Tok::Punct('[') => {
                    if open.len() >= MAX_VALUE_DEPTH {
                        return Err(ScadError::new(
                            pos,
                            format!("vectors nested deeper than {MAX_VALUE_DEPTH} levels: a .csg argument is at most a matrix or a list of points"),
                        ));
                    }
                    open.push((pos, Vec::new()));
                    if self.peek() == Some(&Tok::Punct(']')) {
                        self.i += 1;
                        let (p, items) = open.pop().expect("just pushed");
                        Value {
                            kind: ValueKind::Vector(items),
                            pos: p,
                        }
                    } else {
                        continue;
                    }
                }
                Tok::Punct('-') => match self.next() {
                    Some((Tok::Number(n), _)) => num(-n, pos),
                    Some((Tok::Ident(s), _)) if s == "inf" => num(f64::NEG_INFINITY, pos),
                    Some((Tok::Ident(s), _)) if s == "nan" => num(f64::NAN, pos),
                    _ => {
                        return Err(ScadError::new(
                            pos,
                            "`-` must be followed by a number: a .csg file holds evaluated numbers, no expressions",
                        ))
                    }
                },
                Tok::Number(n) => num(n, pos),
                Tok::Str(s) => Value {
                    kind: ValueKind::Str(s),
                    pos,
                },
                Tok::Ident(s) => Value {
                    kind: match s.as_str() {
                        "true" => ValueKind::Bool(true),
                        "false" => ValueKind::Bool(false),
                        "undef" => ValueKind::Undef,
                        "inf" => ValueKind::Number(f64::INFINITY),
                        "nan" => ValueKind::Number(f64::NAN),
                        _ => {
                            return Err(ScadError::new(
                                pos,
                                format!("`{s}` is not a value: a .csg file holds evaluated values (numbers, true, false, undef, strings, vectors), no variables"),
                            ))
                        }
                    },
                    pos,
                },
                t => {
                    return Err(ScadError::new(
                        pos,
                        format!("expected a value, found {}", describe(&t)),
                    ))
                }
            };
            // Close every vector the scalar completes.
            let mut v = scalar;
            loop {
                let Some((_, items)) = open.last_mut() else {
                    return Ok(v);
                };
                items.push(v);
                match self.next() {
                    Some((Tok::Punct(','), _)) if self.peek() != Some(&Tok::Punct(']')) => break,
                    Some((Tok::Punct(','), _)) | Some((Tok::Punct(']'), _)) => {
                        if self.toks[self.i - 1].0 == Tok::Punct(',') {
                            self.i += 1; // a trailing comma before `]`
                        }
                        let (p, items) = open.pop().expect("non-empty");
                        v = Value {
                            kind: ValueKind::Vector(items),
                            pos: p,
                        };
                    }
                    Some((t, pos)) => {
                        return Err(ScadError::new(
                            pos,
                            format!("expected `,` or `]` in a vector, found {}", describe(&t)),
                        ))
                    }
                    None => {
                        return Err(ScadError::new(
                            open.last().map_or(self.eof, |o| o.0),
                            "this `[` is never closed: add the matching `]`",
                        ))
                    }
                }
            }
        }
    }
}

fn num(n: f64, pos: Pos) -> Value {
    Value {
        kind: ValueKind::Number(n),
        pos,
    }
}
