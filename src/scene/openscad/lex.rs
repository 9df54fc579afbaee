//! Tokens of an OpenSCAD `.csg` file: the subset of OpenSCAD syntax its CSG export
//! prints (node calls with arguments, blocks, modifiers, numbers, strings,
//! vectors), plus `//` and `/* */` comments for hand-written files.

use super::{Pos, ScadError};

#[derive(Clone, Debug, PartialEq)]
pub enum Tok {
    /// A name: node kinds, argument names (`$fn` included), `true`, `inf`, ...
    Ident(String),
    Number(f64),
    Str(String),
    /// One of `( ) { } [ ] , ; = - % # ! *`.
    Punct(char),
}

/// The whole file as tokens with their positions, and the end-of-file position.
pub fn lex(text: &str) -> Result<(Vec<(Tok, Pos)>, Pos), ScadError> {
    let mut out = Vec::new();
    let mut cur = Cursor {
        chars: text.char_indices().peekable(),
        text,
        line: 1,
        col: 1,
    };
    loop {
        cur.skip_space_and_comments()?;
        let pos = cur.pos();
        let Some(c) = cur.peek() else {
            return Ok((out, pos));
        };
        let tok = if c.is_ascii_digit() || c == '.' {
            Tok::Number(cur.number(pos)?)
        } else if c.is_ascii_alphabetic() || c == '_' || c == '$' {
            Tok::Ident(cur.take_while(|c| c.is_ascii_alphanumeric() || c == '_' || c == '$'))
        } else if c == '"' {
            cur.bump();
            Tok::Str(cur.string(pos)?)
        } else if "(){}[],;=-%#!*".contains(c) {
            cur.bump();
            Tok::Punct(c)
        } else {
            return Err(ScadError::new(
                pos,
                format!("unexpected character {c:?}: a .csg file holds node calls such as `cube(size = [1, 1, 1]);`"),
            ));
        };
        out.push((tok, pos));
    }
}

struct Cursor<'a> {
    chars: std::iter::Peekable<std::str::CharIndices<'a>>,
    text: &'a str,
    line: usize,
    col: usize,
}

impl Cursor<'_> {
    fn pos(&self) -> Pos {
        Pos {
            line: self.line,
            col: self.col,
        }
    }

    fn peek(&mut self) -> Option<char> {
        self.chars.peek().map(|&(_, c)| c)
    }

    fn offset(&mut self) -> usize {
        self.chars.peek().map_or(self.text.len(), |&(i, _)| i)
    }

    fn bump(&mut self) -> Option<char> {
        let (_, c) = self.chars.next()?;
        if c == '\n' {
            self.line += 1;
            self.col = 1;
        } else {
            self.col += 1;
        }
        Some(c)
    }

    fn take_while(&mut self, f: impl Fn(char) -> bool) -> String {
        let start = self.offset();
        while self.peek().is_some_and(&f) {
            self.bump();
        }
        let end = self.offset();
        self.text[start..end].to_string()
    }

    fn skip_space_and_comments(&mut self) -> Result<(), ScadError> {
        loop {
            match self.peek() {
                Some(c) if c.is_whitespace() => {
                    self.bump();
                }
                Some('/') => {
                    let pos = self.pos();
                    let (text, off) = (self.text, self.offset());
                    let rest = &text[off..];
                    if rest.starts_with("//") {
                        while self.peek().is_some_and(|c| c != '\n') {
                            self.bump();
                        }
                    } else if rest.starts_with("/*") {
                        self.bump();
                        self.bump();
                        loop {
                            let off = self.offset();
                            if text[off..].starts_with("*/") {
                                self.bump();
                                self.bump();
                                break;
                            }
                            if self.bump().is_none() {
                                return Err(ScadError::new(
                                    pos,
                                    "unterminated comment: close it with `*/`",
                                ));
                            }
                        }
                    } else {
                        return Err(ScadError::new(
                            pos,
                            "unexpected `/`: a .csg file holds no arithmetic (OpenSCAD's export prints evaluated numbers)",
                        ));
                    }
                }
                _ => return Ok(()),
            }
        }
    }

    /// `123`, `1.5`, `.5`, `1e-06`, `2.5E+10` (the sign is a separate `-` token).
    fn number(&mut self, pos: Pos) -> Result<f64, ScadError> {
        let start = self.offset();
        while self.peek().is_some_and(|c| c.is_ascii_digit() || c == '.') {
            self.bump();
        }
        if self.peek().is_some_and(|c| c == 'e' || c == 'E') {
            self.bump();
            if self.peek().is_some_and(|c| c == '+' || c == '-') {
                self.bump();
            }
            while self.peek().is_some_and(|c| c.is_ascii_digit()) {
                self.bump();
            }
        }
        let end = self.offset();
        let s = &self.text[start..end];
        s.parse::<f64>().map_err(|_| {
            ScadError::new(
                pos,
                format!("\"{s}\" is not a number: write numbers as OpenSCAD prints them, e.g. 2, -0.5, 1e-06"),
            )
        })
    }

    /// The body of a string after its opening quote, with OpenSCAD's escapes
    /// (`\"`, `\\`, `\n`, `\t`, `\r`, `\xNN`, `\uNNNN`, `\UNNNNNN`).
    fn string(&mut self, pos: Pos) -> Result<String, ScadError> {
        let mut s = String::new();
        loop {
            let epos = self.pos();
            match self.bump() {
                None => {
                    return Err(ScadError::new(
                        pos,
                        "unterminated string: close it with `\"`",
                    ))
                }
                Some('"') => return Ok(s),
                Some('\\') => {
                    let c = match self.bump() {
                        Some('n') => '\n',
                        Some('t') => '\t',
                        Some('r') => '\r',
                        Some('"') => '"',
                        Some('\\') => '\\',
                        Some(k @ ('x' | 'u' | 'U')) => {
                            let n = match k {
                                'x' => 2,
                                'u' => 4,
                                _ => 6,
                            };
                            let mut v = 0u32;
                            for _ in 0..n {
                                let d = self.peek().and_then(|c| c.to_digit(16)).ok_or_else(|| {
                                    ScadError::new(
                                        epos,
                                        format!("bad escape `\\{k}`: it needs {n} hexadecimal digits"),
                                    )
                                })?;
                                self.bump();
                                v = v * 16 + d;
                            }
                            char::from_u32(v).ok_or_else(|| {
                                ScadError::new(epos, format!("`\\{k}{v:X}` is not a Unicode character"))
                            })?
                        }
                        other => {
                            return Err(ScadError::new(
                                epos,
                                format!(
                                    "unknown escape `\\{}` in a string: use \\\\, \\\", \\n, \\t, \\r, \\xNN or \\uNNNN",
                                    other.map(String::from).unwrap_or_default()
                                ),
                            ))
                        }
                    };
                    s.push(c);
                }
                Some(c) => s.push(c),
            }
        }
    }
}
