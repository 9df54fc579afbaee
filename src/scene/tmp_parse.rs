//! TEMPORARY minimal expression parser — replaced by `csg::parse` at merge.
//!
//! Grammar of CONTRACT.md §1:
//! `expr := term (('+'|'-') term)*`, `term := factor ('*'? factor)*`,
//! `factor := '!' factor | '(' expr ')' | NAME`.

use crate::csg::{Expr, Node, NodeId};
use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub struct ParseError {
    pub src: String,
    /// 1-based character column.
    pub column: usize,
    pub message: String,
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{} (column {})", self.message, self.column)?;
        writeln!(f, "  {}", self.src)?;
        write!(f, "  {}^", " ".repeat(self.column.saturating_sub(1)))
    }
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Name(String),
    Op(char),
    End,
}

struct P<'a> {
    toks: Vec<(Tok, usize)>,
    pos: usize,
    nodes: Vec<Node>,
    src: &'a str,
    resolve: &'a mut dyn FnMut(&str) -> Option<u32>,
}

pub fn parse(src: &str, resolve: &mut dyn FnMut(&str) -> Option<u32>) -> Result<Expr, ParseError> {
    let err = |column: usize, message: String| ParseError {
        src: src.to_string(),
        column,
        message,
    };
    let chars: Vec<char> = src.chars().collect();
    let mut toks = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_whitespace() {
            i += 1;
        } else if "+-*!()".contains(c) {
            toks.push((Tok::Op(c), i + 1));
            i += 1;
        } else if c.is_ascii_alphabetic() || c == '_' {
            let s = i;
            while i < chars.len() && (chars[i].is_ascii_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            toks.push((Tok::Name(chars[s..i].iter().collect()), s + 1));
        } else {
            return Err(err(i + 1, format!("unexpected character `{c}`")));
        }
    }
    toks.push((Tok::End, chars.len() + 1));
    let mut p = P {
        toks,
        pos: 0,
        nodes: Vec::new(),
        src,
        resolve,
    };
    let root = p.expr()?;
    if p.toks[p.pos].0 != Tok::End {
        let (t, c) = p.toks[p.pos].clone();
        return Err(p.err(c, format!("unexpected {}", describe(&t))));
    }
    Ok(Expr {
        nodes: p.nodes,
        root,
    })
}

fn describe(t: &Tok) -> String {
    match t {
        Tok::Name(n) => format!("name `{n}`"),
        Tok::Op(c) => format!("`{c}`"),
        Tok::End => "end of expression".into(),
    }
}

impl P<'_> {
    fn err(&self, column: usize, message: String) -> ParseError {
        ParseError {
            src: self.src.to_string(),
            column,
            message,
        }
    }
    fn push(&mut self, n: Node) -> NodeId {
        self.nodes.push(n);
        self.nodes.len() as NodeId - 1
    }
    fn peek(&self) -> &Tok {
        &self.toks[self.pos].0
    }
    fn expr(&mut self) -> Result<NodeId, ParseError> {
        let mut a = self.term()?;
        while let Tok::Op(c @ ('+' | '-')) = *self.peek() {
            self.pos += 1;
            let b = self.term()?;
            a = self.push(if c == '+' {
                Node::Union(a, b)
            } else {
                Node::Diff(a, b)
            });
        }
        Ok(a)
    }
    fn term(&mut self) -> Result<NodeId, ParseError> {
        let mut a = self.factor()?;
        loop {
            match self.peek() {
                Tok::Op('*') => {
                    self.pos += 1;
                }
                Tok::Op('!') | Tok::Op('(') | Tok::Name(_) => {}
                _ => break,
            }
            let b = self.factor()?;
            a = self.push(Node::Inter(a, b));
        }
        Ok(a)
    }
    fn factor(&mut self) -> Result<NodeId, ParseError> {
        let (t, col) = self.toks[self.pos].clone();
        self.pos += 1;
        match t {
            Tok::Op('!') => {
                let a = self.factor()?;
                Ok(self.push(Node::Not(a)))
            }
            Tok::Op('(') => {
                let a = self.expr()?;
                let (t2, c2) = self.toks[self.pos].clone();
                if t2 != Tok::Op(')') {
                    return Err(self.err(
                        c2,
                        format!(
                            "expected `)` to close the `(` at column {col}, found {}",
                            describe(&t2)
                        ),
                    ));
                }
                self.pos += 1;
                Ok(a)
            }
            Tok::Name(n) => match (self.resolve)(&n) {
                Some(prim) => Ok(self.push(Node::Leaf { prim })),
                None => Err(self.err(
                    col,
                    format!("unknown primitive `{n}`; name a [[primitive]] of this file"),
                )),
            },
            t => Err(self.err(
                col,
                format!(
                    "expected a primitive name, `!` or `(`, found {}",
                    describe(&t)
                ),
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(s: &str) -> Option<u32> {
        ["A", "B", "C", "D", "E"]
            .iter()
            .position(|&n| n == s)
            .map(|i| i as u32)
    }

    #[test]
    fn parses_paper_notation() {
        let e = parse("(A+B)(C-(D-E))", &mut names).unwrap();
        assert_eq!(e.leaves(), vec![0, 1, 2, 3, 4]);
        for bits in 0..32u32 {
            let v = |i: u32| bits >> i & 1 == 1;
            let want = (v(0) || v(1)) && (v(2) && !(v(3) && !v(4)));
            assert_eq!(e.eval(|_, p| v(p)), want);
        }
        let e = parse("A - B - C", &mut names).unwrap();
        assert!(e.eval(|_, p| p == 0));
        assert!(!e.eval(|_, p| p != 1));
    }

    #[test]
    fn errors_have_caret() {
        let e = parse("A + Q", &mut names).unwrap_err();
        assert_eq!(e.column, 5);
        assert!(e.to_string().ends_with("      ^"), "{e}");
        assert_eq!(parse("(A + B", &mut names).unwrap_err().column, 7);
        assert_eq!(parse("A + ", &mut names).unwrap_err().column, 5);
        assert_eq!(parse("A $", &mut names).unwrap_err().column, 3);
    }
}
