//! Parser for the `[csg] expr` grammar (docs/scene-format.md):
//!
//! ```text
//! expr   := term (('+' | '-') term)*     left-associative
//! term   := factor ('*'? factor)*        '*' or juxtaposition: intersection
//! factor := '!' factor | '(' expr ')' | NAME
//! ```
//!
//! Implemented as a shunting-yard over an explicit operator stack (juxtaposition is
//! turned into an implicit `*`), so 10⁵-deep parentheses or complements cannot
//! overflow the call stack. Errors carry a 1-based column (in characters) and print
//! the source with a caret and a hint for the fix.

use super::expr::{Expr, Node, NodeId};
use std::fmt;

/// What went wrong, with the data the message and the hint need.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ParseErrorKind {
    /// Nothing but whitespace.
    EmptyExpression,
    /// A name that `resolve` does not know.
    UnknownPrimitive(String),
    /// A `)` with no matching `(`.
    UnbalancedClose,
    /// A `(` never closed.
    UnclosedOpen,
    /// An operand was expected (after an operator, `(` or `!`, or at the start).
    ExpectedOperand {
        /// The character found instead (`None`: the end of the expression).
        found: Option<char>,
    },
    /// A character outside the grammar.
    UnexpectedChar(char),
}

/// A syntax or name error in a CSG expression.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub struct ParseError {
    /// 1-based column, in characters, of the offending token.
    pub column: usize,
    /// What is wrong.
    pub kind: ParseErrorKind,
    /// The expression as given (for the caret display).
    pub source_text: String,
}

impl ParseError {
    /// The one-line message.
    pub fn message(&self) -> String {
        match &self.kind {
            ParseErrorKind::EmptyExpression => "empty expression".into(),
            ParseErrorKind::UnknownPrimitive(n) => format!("unknown primitive '{n}'"),
            ParseErrorKind::UnbalancedClose => "unbalanced ')'".into(),
            ParseErrorKind::UnclosedOpen => "unclosed '('".into(),
            ParseErrorKind::ExpectedOperand { found: None } => {
                "expected a primitive name, '(' or '!', found the end of the expression".into()
            }
            ParseErrorKind::ExpectedOperand { found: Some(c) } => {
                format!("expected a primitive name, '(' or '!', found '{c}'")
            }
            ParseErrorKind::UnexpectedChar(c) => format!("unexpected character '{c}'"),
        }
    }

    /// How to fix it.
    pub fn hint(&self) -> String {
        match &self.kind {
            ParseErrorKind::EmptyExpression => {
                "write an expression over primitive names, e.g. \"A - B\"".into()
            }
            ParseErrorKind::UnknownPrimitive(n) => format!(
                "define it with [[primitive]] name = \"{n}\" or fix the spelling"
            ),
            ParseErrorKind::UnbalancedClose => "remove this ')' or add a matching '(' before it".into(),
            ParseErrorKind::UnclosedOpen => "add a matching ')' or remove this '('".into(),
            ParseErrorKind::ExpectedOperand { .. } => {
                "an operator ('+', '-', '*') or '!' must be followed by an operand".into()
            }
            ParseErrorKind::UnexpectedChar(_) => {
                "operators are '+', '-', '*' (or juxtaposition), '!'; names are [A-Za-z_][A-Za-z0-9_]*"
                    .into()
            }
        }
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{} (column {})", self.message(), self.column)?;
        writeln!(f, "    {}", self.source_text)?;
        writeln!(f, "    {}^", " ".repeat(self.column.saturating_sub(1)))?;
        write!(f, "hint: {}", self.hint())
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Op {
    Union,
    Diff,
    Inter,
    Not,
    /// An open parenthesis, with its column for the "unclosed" error.
    Open(usize),
}

impl Op {
    fn precedence(self) -> u8 {
        match self {
            Op::Union | Op::Diff => 1,
            Op::Inter => 2,
            Op::Not => 3,
            Op::Open(_) => 0,
        }
    }
}

struct Builder {
    nodes: Vec<Node>,
    values: Vec<NodeId>,
}

impl Builder {
    fn push(&mut self, n: Node) {
        self.nodes.push(n);
        self.values.push(self.nodes.len() as NodeId - 1);
    }
    fn apply(&mut self, op: Op) {
        if op == Op::Not {
            let a = self.values.pop().expect("operand of '!'");
            self.push(Node::Not(a));
            return;
        }
        let b = self.values.pop().expect("right operand");
        let a = self.values.pop().expect("left operand");
        self.push(match op {
            Op::Union => Node::Union(a, b),
            Op::Diff => Node::Diff(a, b),
            Op::Inter => Node::Inter(a, b),
            _ => unreachable!(),
        });
    }
}

/// Parses `src`; `resolve` maps a primitive name to its index (file order) or
/// `None` when it is unknown, which is reported at the name's column.
pub fn parse(src: &str, resolve: &mut dyn FnMut(&str) -> Option<u32>) -> Result<Expr, ParseError> {
    let err = |column: usize, kind: ParseErrorKind| ParseError {
        column,
        kind,
        source_text: src.to_string(),
    };
    let chars: Vec<(usize, char)> = src.char_indices().collect();
    let mut b = Builder {
        nodes: Vec::new(),
        values: Vec::new(),
    };
    let mut ops: Vec<Op> = Vec::new();
    // After an operand (name or ')') we expect an operator; otherwise an operand.
    let mut after_operand = false;
    let mut i = 0;

    // Pushes a binary operator, first applying those it binds looser than
    // (left-associativity: equal precedence is applied first).
    fn push_binary(op: Op, ops: &mut Vec<Op>, b: &mut Builder) {
        while let Some(&top) = ops.last() {
            if !matches!(top, Op::Open(_)) && top.precedence() >= op.precedence() {
                b.apply(top);
                ops.pop();
            } else {
                break;
            }
        }
        ops.push(op);
    }
    // An operand just completed: the pending prefix '!'s bind to it.
    fn close_operand(ops: &mut Vec<Op>, b: &mut Builder) {
        while ops.last() == Some(&Op::Not) {
            ops.pop();
            b.apply(Op::Not);
        }
    }

    while i < chars.len() {
        let (byte, c) = chars[i];
        let column = i + 1;
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        let starts_operand = c == '(' || c == '!' || c == '_' || c.is_ascii_alphabetic();
        if starts_operand && after_operand {
            // Juxtaposition is intersection.
            push_binary(Op::Inter, &mut ops, &mut b);
            after_operand = false;
        }
        match c {
            '+' | '-' | '*' if after_operand => {
                let op = match c {
                    '+' => Op::Union,
                    '-' => Op::Diff,
                    _ => Op::Inter,
                };
                push_binary(op, &mut ops, &mut b);
                after_operand = false;
                i += 1;
            }
            '+' | '-' | '*' | ')' if !after_operand => {
                if c == ')' && !ops.iter().any(|o| matches!(o, Op::Open(_))) {
                    return Err(err(column, ParseErrorKind::UnbalancedClose));
                }
                if b.nodes.is_empty() && ops.is_empty() && src[byte..].trim().is_empty() {
                    return Err(err(column, ParseErrorKind::EmptyExpression));
                }
                return Err(err(
                    column,
                    ParseErrorKind::ExpectedOperand { found: Some(c) },
                ));
            }
            ')' => {
                loop {
                    match ops.pop() {
                        Some(Op::Open(_)) => break,
                        Some(op) => b.apply(op),
                        None => return Err(err(column, ParseErrorKind::UnbalancedClose)),
                    }
                }
                close_operand(&mut ops, &mut b);
                after_operand = true;
                i += 1;
            }
            '(' => {
                ops.push(Op::Open(column));
                i += 1;
            }
            '!' => {
                ops.push(Op::Not);
                i += 1;
            }
            c if c == '_' || c.is_ascii_alphabetic() => {
                let start = byte;
                let mut j = i;
                while j < chars.len() && (chars[j].1 == '_' || chars[j].1.is_ascii_alphanumeric()) {
                    j += 1;
                }
                let end = chars.get(j).map_or(src.len(), |&(b, _)| b);
                let name = &src[start..end];
                let Some(prim) = resolve(name) else {
                    return Err(err(
                        column,
                        ParseErrorKind::UnknownPrimitive(name.to_string()),
                    ));
                };
                b.push(Node::Leaf { prim });
                close_operand(&mut ops, &mut b);
                after_operand = true;
                i = j;
            }
            c => return Err(err(column, ParseErrorKind::UnexpectedChar(c))),
        }
    }
    if !after_operand {
        if b.nodes.is_empty() && ops.is_empty() {
            return Err(err(chars.len().max(1), ParseErrorKind::EmptyExpression));
        }
        return Err(err(
            chars.len() + 1,
            ParseErrorKind::ExpectedOperand { found: None },
        ));
    }
    while let Some(op) = ops.pop() {
        if let Op::Open(col) = op {
            return Err(err(col, ParseErrorKind::UnclosedOpen));
        }
        b.apply(op);
    }
    let root = b.values.pop().expect("a complete expression has one value");
    debug_assert!(b.values.is_empty());
    Ok(Expr {
        nodes: b.nodes,
        root,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: &str) -> Option<u32> {
        match n {
            "A" => Some(0),
            "B" => Some(1),
            "C" => Some(2),
            "D" => Some(3),
            "E" => Some(4),
            "long_name_1" => Some(5),
            _ => None,
        }
    }

    fn p(s: &str) -> Result<Expr, ParseError> {
        parse(s, &mut names)
    }

    /// Canonical fully-parenthesised rendering, iterative.
    fn show(e: &Expr) -> String {
        let mut s: Vec<String> = vec![String::new(); e.nodes.len()];
        for n in e.postorder() {
            let t = match e.nodes[n as usize] {
                Node::Leaf { prim } => ["A", "B", "C", "D", "E", "L"][prim as usize].to_string(),
                Node::Not(a) => format!("!{}", s[a as usize]),
                Node::Union(a, b) => format!("({}+{})", s[a as usize], s[b as usize]),
                Node::Inter(a, b) => format!("({}*{})", s[a as usize], s[b as usize]),
                Node::Diff(a, b) => format!("({}-{})", s[a as usize], s[b as usize]),
            };
            s[n as usize] = t;
        }
        s[e.root as usize].clone()
    }

    #[test]
    fn precedence_and_associativity() {
        assert_eq!(show(&p("A-B-C").unwrap()), "((A-B)-C)");
        assert_eq!(show(&p("A+B C").unwrap()), "(A+(B*C))");
        assert_eq!(show(&p("A+B*C").unwrap()), "(A+(B*C))");
        assert_eq!(show(&p("(A+B)(C-(D-E))").unwrap()), "((A+B)*(C-(D-E)))");
        assert_eq!(show(&p("A B C").unwrap()), "((A*B)*C)");
        assert_eq!(show(&p("!A B").unwrap()), "(!A*B)");
        assert_eq!(show(&p("!(A+B)-C").unwrap()), "(!(A+B)-C)");
        assert_eq!(show(&p("A-!!B+C").unwrap()), "((A-!!B)+C)");
        assert_eq!(show(&p("  long_name_1\t*A ").unwrap()), "(L*A)");
        assert_eq!(show(&p("A(B)C").unwrap()), "((A*B)*C)");
    }

    #[test]
    fn errors_with_columns() {
        let e = p("A + X").unwrap_err();
        assert_eq!(
            (e.column, e.kind.clone()),
            (5, ParseErrorKind::UnknownPrimitive("X".into()))
        );
        let shown = e.to_string();
        assert!(shown.contains("unknown primitive 'X'"), "{shown}");
        assert!(shown.contains("\n    A + X\n        ^\n"), "{shown}");
        assert!(shown.contains("[[primitive]] name = \"X\""), "{shown}");

        assert_eq!(
            p("A + B)").unwrap_err().kind,
            ParseErrorKind::UnbalancedClose
        );
        assert_eq!(p("A + B)").unwrap_err().column, 6);
        let e = p("(A + B").unwrap_err();
        assert_eq!((e.column, e.kind), (1, ParseErrorKind::UnclosedOpen));
        let e = p("A + * B").unwrap_err();
        assert_eq!(
            (e.column, e.kind),
            (5, ParseErrorKind::ExpectedOperand { found: Some('*') })
        );
        let e = p("A +").unwrap_err();
        assert_eq!(
            (e.column, e.kind),
            (4, ParseErrorKind::ExpectedOperand { found: None })
        );
        assert_eq!(p("   ").unwrap_err().kind, ParseErrorKind::EmptyExpression);
        assert_eq!(p("").unwrap_err().kind, ParseErrorKind::EmptyExpression);
        let e = p("()").unwrap_err();
        assert_eq!(
            (e.column, e.kind),
            (2, ParseErrorKind::ExpectedOperand { found: Some(')') })
        );
        let e = p("A & B").unwrap_err();
        assert_eq!((e.column, e.kind), (3, ParseErrorKind::UnexpectedChar('&')));
        // Columns count characters, not bytes.
        let e = p("é + X").unwrap_err();
        assert_eq!(e.column, 1);
        let e = p("(A)+ é").unwrap_err();
        assert_eq!((e.column, e.kind), (6, ParseErrorKind::UnexpectedChar('é')));
        let e = p("A - !").unwrap_err();
        assert_eq!(e.column, 6);
    }

    #[test]
    fn deep_nesting() {
        let n = 100_000;
        let s = format!("{}A{}", "(".repeat(n), ")".repeat(n));
        let e = p(&s).unwrap();
        assert_eq!(e.nodes.len(), 1);
        let s = format!("{}A", "!".repeat(n));
        let e = p(&s).unwrap();
        assert_eq!(e.nodes.len(), n + 1);
        assert!(e.eval(|_, _| true));
        // Right-nested: A-(B-(A-(B-...))).
        let mut s = String::new();
        for _ in 0..n {
            s.push_str("A-(");
        }
        s.push('B');
        s.push_str(&")".repeat(n));
        let e = p(&s).unwrap();
        assert_eq!(e.leaves().len(), n + 1);
    }

    #[test]
    fn million_leaves() {
        let n = 1_000_000;
        let mut s = String::with_capacity(4 * n);
        for i in 0..n {
            if i > 0 {
                s.push_str(if i % 3 == 0 { " + " } else { " " });
            }
            s.push(if i % 2 == 0 { 'A' } else { 'B' });
        }
        let e = p(&s).unwrap();
        assert_eq!(e.leaves().len(), n);
    }
}
