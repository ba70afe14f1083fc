//! Derived fields: a base scene field written `{"expr": "settle_s + 200 / frequency_hz"}` takes,
//! at every grid point, the value of that expression of the point's axis values (by axis name)
//! and of the base scene's numbers (by dotted path).
//!
//! The language is small and safe: numbers (`1e-3`), names, `+ - * /`, `^` (power, right
//! associative), unary minus, parentheses, the constant `pi` and the functions `sqrt`, `exp`,
//! `log` (natural), `log10`, `abs`, `min(a, b, …)`, `max(a, b, …)`; no loops, no I/O, no
//! recursion into other derived fields. An expression follows the axes of one dimension (axes
//! zipped together count as one): the derived field becomes one more axis zipped onto that
//! dimension, its values computed here, so the runs, their hashes and the output's coordinates
//! see an ordinary axis. An expression of no axis is a constant, set in the base.

use serde_json::{Map, Value};

use crate::error::{Error, Result};

/// A parsed expression.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    /// A number.
    Num(f64),
    /// A name (an axis, or a dotted path of the base scene).
    Name(String),
    /// `-a`.
    Neg(Box<Expr>),
    /// `a op b`.
    Bin(char, Box<Expr>, Box<Expr>),
    /// A function of its arguments.
    Call(String, Vec<Expr>),
}

/// The functions an expression may call, with their arities (`None`: one or more).
const FUNCTIONS: &[(&str, Option<usize>)] = &[
    ("sqrt", Some(1)),
    ("exp", Some(1)),
    ("log", Some(1)),
    ("log10", Some(1)),
    ("abs", Some(1)),
    ("min", None),
    ("max", None),
];

/// The most characters of an expression.
pub const MAX_EXPR_CHARS: usize = 1000;

struct Parser<'a> {
    s: &'a [u8],
    at: usize,
    depth: usize,
}

/// A parse error: the position (0-based, in characters of ASCII text) and what is wrong.
type ParseError = (usize, String);

impl Parser<'_> {
    fn skip(&mut self) {
        while self.at < self.s.len() && self.s[self.at].is_ascii_whitespace() {
            self.at += 1;
        }
    }

    fn peek(&mut self) -> Option<u8> {
        self.skip();
        self.s.get(self.at).copied()
    }

    fn expr(&mut self) -> std::result::Result<Expr, ParseError> {
        self.depth += 1;
        if self.depth > 64 {
            return Err((self.at, "nests deeper than 64 levels".into()));
        }
        let mut a = self.term()?;
        while let Some(op @ (b'+' | b'-')) = self.peek() {
            self.at += 1;
            let b = self.term()?;
            a = Expr::Bin(op as char, Box::new(a), Box::new(b));
        }
        self.depth -= 1;
        Ok(a)
    }

    fn term(&mut self) -> std::result::Result<Expr, ParseError> {
        let mut a = self.unary()?;
        while let Some(op @ (b'*' | b'/')) = self.peek() {
            self.at += 1;
            let b = self.unary()?;
            a = Expr::Bin(op as char, Box::new(a), Box::new(b));
        }
        Ok(a)
    }

    fn unary(&mut self) -> std::result::Result<Expr, ParseError> {
        if self.peek() == Some(b'-') {
            self.at += 1;
            return Ok(Expr::Neg(Box::new(self.unary()?)));
        }
        if self.peek() == Some(b'+') {
            self.at += 1;
            return self.unary();
        }
        self.power()
    }

    fn power(&mut self) -> std::result::Result<Expr, ParseError> {
        let base = self.atom()?;
        if self.peek() == Some(b'^') {
            self.at += 1;
            // Right associative, and binding tighter than a unary minus on its left: -2^2 = -4.
            let exponent = self.unary()?;
            return Ok(Expr::Bin('^', Box::new(base), Box::new(exponent)));
        }
        Ok(base)
    }

    fn atom(&mut self) -> std::result::Result<Expr, ParseError> {
        let start = {
            self.skip();
            self.at
        };
        match self.peek() {
            None => Err((
                start,
                "ends where a number, a name or `(` is expected".into(),
            )),
            Some(b'(') => {
                self.at += 1;
                let e = self.expr()?;
                if self.peek() != Some(b')') {
                    return Err((self.at, "expects `)`".into()));
                }
                self.at += 1;
                Ok(e)
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => {
                let mut end = self.at;
                while end < self.s.len() && (self.s[end].is_ascii_digit() || self.s[end] == b'.') {
                    end += 1;
                }
                if end < self.s.len() && (self.s[end] == b'e' || self.s[end] == b'E') {
                    let mut e = end + 1;
                    if e < self.s.len() && (self.s[e] == b'+' || self.s[e] == b'-') {
                        e += 1;
                    }
                    if e < self.s.len() && self.s[e].is_ascii_digit() {
                        while e < self.s.len() && self.s[e].is_ascii_digit() {
                            e += 1;
                        }
                        end = e;
                    }
                }
                let text = std::str::from_utf8(&self.s[self.at..end]).expect("ASCII");
                let x: f64 = text
                    .parse()
                    .map_err(|_| (start, format!("`{text}` is not a number")))?;
                self.at = end;
                Ok(Expr::Num(x))
            }
            Some(c) if c.is_ascii_alphabetic() || c == b'_' => {
                let mut end = self.at;
                while end < self.s.len()
                    && (self.s[end].is_ascii_alphanumeric()
                        || matches!(self.s[end], b'_' | b'.' | b'[' | b']'))
                {
                    end += 1;
                }
                let name = std::str::from_utf8(&self.s[self.at..end])
                    .expect("ASCII")
                    .to_string();
                self.at = end;
                if self.peek() == Some(b'(') {
                    let Some((_, arity)) = FUNCTIONS.iter().find(|(f, _)| *f == name) else {
                        return Err((
                            start,
                            format!(
                                "`{name}` is no function; functions: {}",
                                FUNCTIONS.iter().map(|f| f.0).collect::<Vec<_>>().join(", ")
                            ),
                        ));
                    };
                    self.at += 1;
                    let mut args = vec![self.expr()?];
                    while self.peek() == Some(b',') {
                        self.at += 1;
                        args.push(self.expr()?);
                    }
                    if self.peek() != Some(b')') {
                        return Err((self.at, "expects `,` or `)`".into()));
                    }
                    self.at += 1;
                    if arity.is_some_and(|n| n != args.len()) {
                        return Err((
                            start,
                            format!("`{name}` takes one argument, got {}", args.len()),
                        ));
                    }
                    return Ok(Expr::Call(name, args));
                }
                if name == "pi" {
                    return Ok(Expr::Num(std::f64::consts::PI));
                }
                Ok(Expr::Name(name))
            }
            Some(c) => Err((start, format!("unexpected `{}`", c as char))),
        }
    }
}

/// Parses `text`; an error says where (a 1-based character position) and what.
pub fn parse(text: &str) -> std::result::Result<Expr, String> {
    if text.len() > MAX_EXPR_CHARS {
        return Err(format!("is longer than {MAX_EXPR_CHARS} characters"));
    }
    if let Some(i) = text.chars().position(|c| !c.is_ascii()) {
        return Err(format!("at position {}: only ASCII text is read", i + 1));
    }
    let mut p = Parser {
        s: text.as_bytes(),
        at: 0,
        depth: 0,
    };
    let e = p
        .expr()
        .map_err(|(at, m)| format!("at position {}: {m}", at + 1))?;
    if p.peek().is_some() {
        return Err(format!(
            "at position {}: unexpected `{}` after a complete expression",
            p.at + 1,
            p.s[p.at] as char
        ));
    }
    Ok(e)
}

impl Expr {
    /// Every name it reads, in order of first appearance.
    pub fn names(&self) -> Vec<String> {
        fn walk(e: &Expr, out: &mut Vec<String>) {
            match e {
                Expr::Num(_) => {}
                Expr::Name(n) => {
                    if !out.contains(n) {
                        out.push(n.clone());
                    }
                }
                Expr::Neg(a) => walk(a, out),
                Expr::Bin(_, a, b) => {
                    walk(a, out);
                    walk(b, out);
                }
                Expr::Call(_, args) => args.iter().for_each(|a| walk(a, out)),
            }
        }
        let mut out = Vec::new();
        walk(self, &mut out);
        out
    }

    /// Its value, names read through `get`.
    pub fn eval(&self, get: &dyn Fn(&str) -> f64) -> f64 {
        match self {
            Expr::Num(x) => *x,
            Expr::Name(n) => get(n),
            Expr::Neg(a) => -a.eval(get),
            Expr::Bin(op, a, b) => {
                let (a, b) = (a.eval(get), b.eval(get));
                match op {
                    '+' => a + b,
                    '-' => a - b,
                    '*' => a * b,
                    '/' => a / b,
                    _ => a.powf(b),
                }
            }
            Expr::Call(f, args) => {
                let v: Vec<f64> = args.iter().map(|a| a.eval(get)).collect();
                match f.as_str() {
                    "sqrt" => v[0].sqrt(),
                    "exp" => v[0].exp(),
                    "log" => v[0].ln(),
                    "log10" => v[0].log10(),
                    "abs" => v[0].abs(),
                    "min" => v.iter().copied().fold(f64::INFINITY, f64::min),
                    _ => v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                }
            }
        }
    }
}

/// A derived field of the base scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Derived {
    /// Its dotted path.
    pub field: String,
    /// The expression as written.
    pub text: String,
    /// Parsed.
    pub expr: Expr,
}

fn find(v: &Value, path: &mut Vec<String>, out: &mut Vec<(String, String)>) {
    match v {
        Value::Object(m) => {
            if m.len() == 1 {
                if let Some(Value::String(text)) = m.get("expr") {
                    out.push((path.join("."), text.clone()));
                    return;
                }
            }
            for (k, x) in m {
                path.push(k.clone());
                find(x, path, out);
                path.pop();
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                path.push(i.to_string());
                find(x, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

/// The first value of every axis of the raw `axes` list, by name (its `name`, else its field's
/// last part): what a derived field is evaluated at to stand in the base while the base is
/// checked.
fn first_values(axes: &[Value]) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    for a in axes {
        if let Some(Value::Array(z)) = a.get("zip") {
            out.extend(first_values(z));
            continue;
        }
        let name = a
            .get("name")
            .and_then(Value::as_str)
            .map(str::to_string)
            .or_else(|| {
                a.get("field")
                    .and_then(Value::as_str)
                    .and_then(|f| super::split_path(f).last().cloned())
            });
        let first = a
            .get("values")
            .and_then(|v| v.get(0))
            .and_then(Value::as_f64)
            .or_else(|| a.pointer("/range/start").and_then(Value::as_f64));
        if let (Some(n), Some(x)) = (name, first) {
            out.push((n, x));
        }
    }
    out
}

/// Takes the derived fields out of the raw `base` (each replaced by its value at the axes' first
/// values, so that the base is checked as a scene), parsed; errors name `base.FIELD` and the
/// position in the expression.
pub fn extract(base: &mut Map<String, Value>, axes: &[Value]) -> Result<Vec<Derived>> {
    let mut found = Vec::new();
    find(&Value::Object(base.clone()), &mut Vec::new(), &mut found);
    let firsts = first_values(axes);
    let raw = Value::Object(base.clone());
    let mut out = Vec::new();
    for (field, text) in found {
        let at = format!("base.{field}");
        let expr =
            parse(&text).map_err(|m| Error::input(&at, format!("the expression `{text}` {m}")))?;
        let stand_in = expr.eval(&|n| {
            firsts
                .iter()
                .find(|(a, _)| a == n)
                .map(|(_, x)| *x)
                .or_else(|| super::lookup(&raw, n).ok().and_then(Value::as_f64))
                .unwrap_or(1.0)
        });
        let mut v = Value::Object(std::mem::take(base));
        super::set_path(
            &mut v,
            &field,
            Value::from(if stand_in.is_finite() { stand_in } else { 1.0 }),
        );
        let Value::Object(m) = v else { unreachable!() };
        *base = m;
        out.push(Derived { field, text, expr });
    }
    Ok(out)
}

/// Adds each derived field to `dims` as an axis zipped onto the one dimension whose axes its
/// expression reads (or sets the base, when it reads none), its values computed at every value of
/// that dimension; `base` (normalised) gives the numbers named by dotted paths.
pub fn apply(derived: &[Derived], base: &mut Value, dims: &mut [super::Dim]) -> Result<()> {
    for d in derived {
        let at = format!("base.{}", d.field);
        let names = d.expr.names();
        let mut dim: Option<usize> = None;
        let mut constants: Vec<(String, f64)> = Vec::new();
        for n in &names {
            let owner = dims
                .iter()
                .position(|dm| dm.axes.iter().any(|a| &a.name == n));
            match (owner, dim) {
                (Some(k), None) => dim = Some(k),
                (Some(k), Some(j)) if k != j => {
                    return Err(Error::input(
                        &at,
                        format!(
                            "the expression `{}` reads axes of two dimensions (`{}` and `{n}`): an expression follows the axes of one dimension (zip the axes it reads)",
                            d.text,
                            names.iter().find(|m| dims[j].axes.iter().any(|a| &a.name == *m)).cloned().unwrap_or_default()
                        ),
                    ))
                }
                (Some(_), Some(_)) => {}
                (None, _) => {
                    if derived.iter().any(|o| o.field == *n) {
                        return Err(Error::input(&at, format!("the expression `{}` reads `{n}`, itself a derived field: write its expression in", d.text)));
                    }
                    match super::lookup(base, n).ok().and_then(Value::as_f64) {
                        Some(x) => constants.push((n.clone(), x)),
                        None => {
                            let axes: Vec<&str> = dims.iter().flat_map(|dm| dm.axes.iter().map(|a| a.name.as_str())).collect();
                            return Err(Error::input(
                                &at,
                                format!(
                                    "the expression `{}` reads `{n}`, which is neither an axis ({}) nor a number of the base scene (a dotted path such as physics.damping_kg_s)",
                                    d.text,
                                    if axes.is_empty() { "the sweep has none".to_string() } else { axes.join(", ") }
                                ),
                            ));
                        }
                    }
                }
            }
        }
        let value_at = |k: Option<usize>| -> Result<f64> {
            let x = d.expr.eval(&|n| {
                if let (Some(dm), Some(k)) = (dim, k) {
                    if let Some(a) = dims[dm].axes.iter().find(|a| a.name == n) {
                        return a.values[k].as_f64().unwrap_or(f64::NAN);
                    }
                }
                constants
                    .iter()
                    .find(|(c, _)| c == n)
                    .map_or(f64::NAN, |(_, x)| *x)
            });
            if x.is_finite() {
                Ok(x)
            } else {
                Err(Error::input(
                    &at,
                    format!(
                        "the expression `{}` gives {x}{}: no number",
                        d.text,
                        k.map(|k| format!(" at value {k} of its dimension"))
                            .unwrap_or_default()
                    ),
                ))
            }
        };
        match dim {
            None => super::set_path(base, &d.field, Value::from(value_at(None)?)),
            Some(dm) => {
                let values = (0..dims[dm].len())
                    .map(|k| value_at(Some(k)).map(Value::from))
                    .collect::<Result<Vec<_>>>()?;
                let name = super::field_name(&d.field);
                dims[dm].axes.push(super::Axis {
                    units: super::units_of(&d.field),
                    name,
                    field: d.field.clone(),
                    values,
                    origin: at,
                });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value(text: &str) -> f64 {
        parse(text).unwrap().eval(&|n| match n {
            "f" => 4000.0,
            "settle_s" => 0.1,
            _ => f64::NAN,
        })
    }

    #[test]
    fn arithmetic_follows_the_usual_precedence() {
        assert_eq!(value("1 + 2 * 3"), 7.0);
        assert_eq!(value("(1 + 2) * 3"), 9.0);
        assert_eq!(value("2 ^ 3 ^ 2"), 512.0);
        assert_eq!(value("-2 ^ 2"), -4.0);
        assert_eq!(value("1020 / f"), 1020.0 / 4000.0);
        assert_eq!(value("settle_s + 200 / f"), 0.1 + 200.0 / 4000.0);
        assert_eq!(value("max(1, sqrt(16), min(9, 3))"), 4.0);
        assert_eq!(value("2.5e-3 * 4"), 0.01);
        assert!((value("log(exp(2))") - 2.0).abs() < 1e-15);
        assert!((value("2 * pi") - std::f64::consts::TAU).abs() < 1e-15);
    }

    #[test]
    fn errors_say_where() {
        assert_eq!(
            parse("1 + ").unwrap_err(),
            "at position 5: ends where a number, a name or `(` is expected"
        );
        assert_eq!(
            parse("2 * (f + 1").unwrap_err(),
            "at position 11: expects `)`"
        );
        assert!(parse("cos(f)")
            .unwrap_err()
            .starts_with("at position 1: `cos` is no function"));
        assert_eq!(
            parse("f f").unwrap_err(),
            "at position 3: unexpected `f` after a complete expression"
        );
        assert!(parse("sqrt(1, 2)")
            .unwrap_err()
            .contains("takes one argument"));
        assert!(parse(&"(".repeat(100))
            .unwrap_err()
            .contains("nests deeper"));
    }
}
