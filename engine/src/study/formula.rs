//! Formulas of a study's reference: arithmetic on floats with the swept parameters as
//! variables (`2 / sqrt(k_n / 9.8e-4)`, `0.7 * (1 + 0 * time_step_fraction)`).
//!
//! Grammar: `+ - * / ^` (power, right-associative), unary minus, parentheses, numbers
//! (`1`, `2.5e-3`), the constants `pi` and `e`, variables, and the functions `sqrt exp ln log10
//! abs sin cos tan`, and `min(a, b)`, `max(a, b)`, `pow(a, b)`. Every value is a float: `1/2` is
//! 0.5.

use std::collections::BTreeMap;

/// A parsed formula.
#[derive(Debug, Clone, PartialEq)]
pub struct Formula {
    text: String,
    root: Node,
}

#[derive(Debug, Clone, PartialEq)]
enum Node {
    Num(f64),
    Var(String),
    Neg(Box<Node>),
    Bin(char, Box<Node>, Box<Node>),
    Call(String, Vec<Node>),
}

const FUNCTIONS: [(&str, usize); 11] =
    [("sqrt", 1), ("exp", 1), ("ln", 1), ("log10", 1), ("abs", 1), ("sin", 1), ("cos", 1), ("tan", 1), ("min", 2), ("max", 2), ("pow", 2)];

struct Parser<'a> {
    s: &'a [u8],
    at: usize,
}

impl Parser<'_> {
    fn skip(&mut self) {
        while self.s.get(self.at).is_some_and(|c| c.is_ascii_whitespace()) {
            self.at += 1;
        }
    }
    fn peek(&mut self) -> Option<u8> {
        self.skip();
        self.s.get(self.at).copied()
    }
    fn fail<T>(&self, what: &str) -> Result<T, String> {
        Err(format!("{what} at character {}", self.at + 1))
    }
    fn expr(&mut self) -> Result<Node, String> {
        let mut left = self.term()?;
        while let Some(c @ (b'+' | b'-')) = self.peek() {
            self.at += 1;
            left = Node::Bin(c as char, Box::new(left), Box::new(self.term()?));
        }
        Ok(left)
    }
    fn term(&mut self) -> Result<Node, String> {
        let mut left = self.unary()?;
        while let Some(c @ (b'*' | b'/')) = self.peek() {
            self.at += 1;
            left = Node::Bin(c as char, Box::new(left), Box::new(self.unary()?));
        }
        Ok(left)
    }
    fn unary(&mut self) -> Result<Node, String> {
        if self.peek() == Some(b'-') {
            self.at += 1;
            return Ok(Node::Neg(Box::new(self.unary()?)));
        }
        if self.peek() == Some(b'+') {
            self.at += 1;
            return self.unary();
        }
        self.power()
    }
    fn power(&mut self) -> Result<Node, String> {
        let base = self.atom()?;
        if self.peek() == Some(b'^') {
            self.at += 1;
            return Ok(Node::Bin('^', Box::new(base), Box::new(self.unary()?)));
        }
        Ok(base)
    }
    fn atom(&mut self) -> Result<Node, String> {
        match self.peek() {
            Some(b'(') => {
                self.at += 1;
                let e = self.expr()?;
                if self.peek() != Some(b')') {
                    return self.fail("expected ')'");
                }
                self.at += 1;
                Ok(e)
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => {
                let start = self.at;
                while self.s.get(self.at).is_some_and(|c| c.is_ascii_digit() || *c == b'.') {
                    self.at += 1;
                }
                if matches!(self.s.get(self.at), Some(b'e' | b'E'))
                    && self.s.get(self.at + 1).is_some_and(|c| c.is_ascii_digit() || *c == b'-' || *c == b'+')
                {
                    self.at += 2;
                    while self.s.get(self.at).is_some_and(|c| c.is_ascii_digit()) {
                        self.at += 1;
                    }
                }
                let text = std::str::from_utf8(&self.s[start..self.at]).unwrap_or_default();
                text.parse().map(Node::Num).or_else(|_| self.fail(&format!("'{text}' is not a number")))
            }
            Some(c) if c.is_ascii_alphabetic() || c == b'_' => {
                let start = self.at;
                while self.s.get(self.at).is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_') {
                    self.at += 1;
                }
                let name = std::str::from_utf8(&self.s[start..self.at]).unwrap_or_default().to_string();
                if self.peek() != Some(b'(') {
                    return Ok(Node::Var(name));
                }
                self.at += 1;
                let Some(&(_, arity)) = FUNCTIONS.iter().find(|(f, _)| *f == name) else {
                    let known: Vec<&str> = FUNCTIONS.iter().map(|f| f.0).collect();
                    return self.fail(&format!("unknown function '{name}' (known: {})", known.join(", ")));
                };
                let mut args = vec![self.expr()?];
                while self.peek() == Some(b',') {
                    self.at += 1;
                    args.push(self.expr()?);
                }
                if self.peek() != Some(b')') {
                    return self.fail("expected ')'");
                }
                self.at += 1;
                if args.len() != arity {
                    return self.fail(&format!("{name} takes {arity} argument(s), got {}", args.len()));
                }
                Ok(Node::Call(name, args))
            }
            Some(c) => self.fail(&format!("unexpected '{}'", c as char)),
            None => self.fail("unexpected end"),
        }
    }
}

impl Formula {
    /// Parses a formula; the error says what is wrong and where.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut p = Parser { s: text.as_bytes(), at: 0 };
        let root = p.expr()?;
        if p.peek().is_some() {
            return p.fail("unexpected text");
        }
        Ok(Self { text: text.to_string(), root })
    }

    /// The variables the formula uses (constants left out).
    pub fn variables(&self) -> Vec<String> {
        fn walk(n: &Node, out: &mut Vec<String>) {
            match n {
                Node::Var(v) if v != "pi" && v != "e" && !out.contains(v) => out.push(v.clone()),
                Node::Neg(a) => walk(a, out),
                Node::Bin(_, a, b) => {
                    walk(a, out);
                    walk(b, out);
                }
                Node::Call(_, args) => args.iter().for_each(|a| walk(a, out)),
                _ => {}
            }
        }
        let mut out = Vec::new();
        walk(&self.root, &mut out);
        out
    }

    /// Evaluates with the given variables.
    pub fn eval(&self, vars: &BTreeMap<String, f64>) -> Result<f64, String> {
        fn ev(n: &Node, vars: &BTreeMap<String, f64>) -> Result<f64, String> {
            Ok(match n {
                Node::Num(x) => *x,
                Node::Var(v) => match (v.as_str(), vars.get(v)) {
                    (_, Some(x)) => *x,
                    ("pi", None) => std::f64::consts::PI,
                    ("e", None) => std::f64::consts::E,
                    _ => return Err(format!("unknown variable '{v}'")),
                },
                Node::Neg(a) => -ev(a, vars)?,
                Node::Bin(op, a, b) => {
                    let (a, b) = (ev(a, vars)?, ev(b, vars)?);
                    match op {
                        '+' => a + b,
                        '-' => a - b,
                        '*' => a * b,
                        '/' => a / b,
                        _ => a.powf(b),
                    }
                }
                Node::Call(f, args) => {
                    let x: Vec<f64> = args.iter().map(|a| ev(a, vars)).collect::<Result<_, _>>()?;
                    match f.as_str() {
                        "sqrt" => x[0].sqrt(),
                        "exp" => x[0].exp(),
                        "ln" => x[0].ln(),
                        "log10" => x[0].log10(),
                        "abs" => x[0].abs(),
                        "sin" => x[0].sin(),
                        "cos" => x[0].cos(),
                        "tan" => x[0].tan(),
                        "min" => x[0].min(x[1]),
                        "max" => x[0].max(x[1]),
                        _ => x[0].powf(x[1]),
                    }
                }
            })
        }
        let v = ev(&self.root, vars)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(format!("'{}' is not finite ({v}) for {vars:?}", self.text))
        }
    }
}

/// The variable name of a swept parameter: its last field (`k_n` for
/// `materials.glass.contact.k_n`).
pub fn variable_of(path: &str) -> String {
    path.rsplit('.').next().unwrap_or(path).split('[').next().unwrap_or(path).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formulas_follow_arithmetic_on_floats() {
        let vars: BTreeMap<String, f64> = [("k_n".to_string(), 4.0), ("m".to_string(), 1.0)].into_iter().collect();
        let ev = |t: &str| Formula::parse(t).and_then(|f| f.eval(&vars));
        assert_eq!(ev("1/2"), Ok(0.5));
        assert_eq!(ev("2 / sqrt(k_n / m)"), Ok(1.0));
        assert_eq!(ev("-2^2"), Ok(-4.0));
        assert_eq!(ev("2^3^2"), Ok(512.0));
        assert_eq!(ev("1 + 2 * 3 - 4 / 2"), Ok(5.0));
        assert_eq!(ev("max(k_n, 5) + min(1, 2) + pow(2, 3)"), Ok(14.0));
        assert_eq!(ev("2.5e-3 * 1e3"), Ok(2.5));
        assert!((ev("cos(pi)").unwrap_or(0.0) + 1.0).abs() < 1e-15);
        assert!(ev("sqrt(k_n").is_err_and(|e| e.contains("expected ')'")));
        assert!(ev("foo(1)").is_err_and(|e| e.starts_with("unknown function 'foo'")));
        assert!(ev("x + 1").is_err_and(|e| e == "unknown variable 'x'"));
        assert!(ev("1 / 0").is_err_and(|e| e.contains("not finite")));
        assert!(ev("1 2").is_err_and(|e| e.starts_with("unexpected text")));
        assert_eq!(Formula::parse("2*pi*sqrt(m/k_n)").map(|f| f.variables()), Ok(vec!["m".to_string(), "k_n".to_string()]));
        assert_eq!(variable_of("materials.glass.contact.k_n"), "k_n");
        assert_eq!(variable_of("particles[0].count"), "count");
    }
}
