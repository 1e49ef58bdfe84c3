//! Just enough of OpenFOAM's dictionary syntax to read a case's parameters: entries
//! `key value ...;` and `key { ... }`, comments, `$name` references (looked up in the
//! enclosing dictionaries, innermost first) and `#eval{ ... }` arithmetic, as v1912 evaluates it.

#[derive(Debug, Clone, PartialEq)]
pub enum Entry {
    /// The tokens between the key and the `;`.
    Value(Vec<String>),
    Dict(Dict),
}

#[derive(Debug, Clone, PartialEq, Default)]
pub struct Dict {
    pub entries: Vec<(String, Entry)>,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DictError {
    #[error("unexpected end of file inside a dictionary or entry")]
    Eof,
    #[error("unexpected `{0}`")]
    Unexpected(String),
    #[error("no entry `{0}`")]
    Missing(String),
    #[error("`{0}` is not a number: {1}")]
    NotNumber(String, String),
    #[error("`{0}` refers to `${1}`, which is not defined")]
    Undefined(String, String),
}

fn strip_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            i += 2;
            while i + 1 < b.len() && !(b[i] == b'*' && b[i + 1] == b'/') {
                i += 1;
            }
            i += 2;
            out.push(' ');
        } else {
            let c = text[i..].chars().next().expect("in bounds");
            out.push(c);
            i += c.len_utf8();
        }
    }
    out
}

/// Whether a mesh description (a blockMeshDict or a polyMesh boundary file) has a patch of
/// type `empty`: the mark of a 2D (one cell thick) OpenFOAM case.
pub fn has_empty_patch(text: &str) -> bool {
    tokenize(text)
        .windows(2)
        .any(|w| w[0] == "type" && w[1] == "empty")
}

/// Tokens: words, `"strings"`, and the punctuation `{ } ( ) ;`; `#eval{...}` is one token.
fn tokenize(text: &str) -> Vec<String> {
    let text = strip_comments(text);
    let mut toks = Vec::new();
    let mut cur = String::new();
    let mut chars = text.chars().peekable();
    let flush = |cur: &mut String, toks: &mut Vec<String>| {
        if !cur.is_empty() {
            toks.push(std::mem::take(cur));
        }
    };
    while let Some(c) = chars.next() {
        match c {
            '#' => {
                flush(&mut cur, &mut toks);
                toks.push(directive(&mut chars));
            }
            '"' => {
                flush(&mut cur, &mut toks);
                toks.push(quoted(&mut chars));
            }
            '{' | '}' | '(' | ')' | ';' => {
                flush(&mut cur, &mut toks);
                toks.push(c.to_string());
            }
            c if c.is_whitespace() => flush(&mut cur, &mut toks),
            c => cur.push(c),
        }
    }
    flush(&mut cur, &mut toks);
    toks
}

type Chars<'a> = std::iter::Peekable<std::str::Chars<'a>>;

/// A directive, its `#` already read: `#eval{...}` as one token, any other as its word.
fn directive(chars: &mut Chars) -> String {
    let mut word = String::from("#");
    while let Some(&n) = chars.peek() {
        if n.is_alphanumeric() {
            word.push(n);
            chars.next();
        } else {
            break;
        }
    }
    if word == "#eval" {
        while chars.peek().is_some_and(|c| c.is_whitespace()) {
            chars.next();
        }
        if chars.peek() == Some(&'{') {
            chars.next();
            return format!("#eval{{{}}}", braced_body(chars));
        }
    }
    word
}

/// What follows an opened `{` up to the `}` that closes it (consumed, not returned); braces
/// inside are kept.
fn braced_body(chars: &mut Chars) -> String {
    let mut depth = 1;
    let mut body = String::new();
    for n in chars.by_ref() {
        match n {
            '{' => depth += 1,
            '}' => depth -= 1,
            _ => {}
        }
        if depth == 0 {
            break;
        }
        body.push(n);
    }
    body
}

/// A string, its opening `"` already read, with both quotes.
fn quoted(chars: &mut Chars) -> String {
    let mut s = String::from("\"");
    for n in chars.by_ref() {
        s.push(n);
        if n == '"' {
            break;
        }
    }
    s
}

pub fn parse(text: &str) -> Result<Dict, DictError> {
    let toks = tokenize(text);
    let mut pos = 0;
    let d = parse_dict(&toks, &mut pos, true)?;
    Ok(d)
}

fn parse_dict(toks: &[String], pos: &mut usize, top: bool) -> Result<Dict, DictError> {
    let mut d = Dict::default();
    loop {
        let Some(key) = toks.get(*pos) else {
            return if top { Ok(d) } else { Err(DictError::Eof) };
        };
        *pos += 1;
        match key.as_str() {
            "}" if !top => return Ok(d),
            "}" | "{" | "(" | ")" => return Err(DictError::Unexpected(key.clone())),
            ";" => continue,
            _ => {}
        }
        if key.starts_with('#') {
            // Directives such as #include or #inputMode: skip to the end of the line's entry.
            if key == "#include" || key == "#includeEtc" || key == "#includeIfPresent" {
                *pos += 1;
            }
            continue;
        }
        if toks.get(*pos).map(String::as_str) == Some("{") {
            *pos += 1;
            let sub = parse_dict(toks, pos, false)?;
            d.entries.push((key.clone(), Entry::Dict(sub)));
            continue;
        }
        let mut value = Vec::new();
        let mut depth = 0i32;
        loop {
            let t = toks.get(*pos).ok_or(DictError::Eof)?;
            *pos += 1;
            match t.as_str() {
                ";" if depth == 0 => break,
                "(" => depth += 1,
                ")" => depth -= 1,
                // A dictionary inside a list: keep its tokens.
                "{" => depth += 1,
                "}" => depth -= 1,
                _ => {}
            }
            value.push(t.clone());
        }
        d.entries.push((key.clone(), Entry::Value(value)));
    }
}

impl Dict {
    pub fn get(&self, key: &str) -> Option<&Entry> {
        // The last definition wins, as in OpenFOAM.
        self.entries
            .iter()
            .rev()
            .find(|(k, _)| k == key)
            .map(|(_, e)| e)
    }

    pub fn dict(&self, key: &str) -> Option<&Dict> {
        match self.get(key) {
            Some(Entry::Dict(d)) => Some(d),
            _ => None,
        }
    }

    pub fn value(&self, key: &str) -> Option<&[String]> {
        match self.get(key) {
            Some(Entry::Value(v)) => Some(v),
            _ => None,
        }
    }
}

/// Looks `key` up in `scopes` (innermost last) and reads it as numbers: a scalar gives one,
/// a vector `(x y z)` three. `$name` and `#eval{}` are resolved in the same scopes.
pub fn numbers(scopes: &[&Dict], key: &str) -> Result<Vec<f64>, DictError> {
    let tokens = scopes
        .iter()
        .rev()
        .find_map(|d| d.value(key))
        .ok_or_else(|| DictError::Missing(key.to_string()))?;
    let mut out = Vec::new();
    for t in tokens.iter().filter(|t| *t != "(" && *t != ")") {
        out.push(number(scopes, key, t, 0)?);
    }
    Ok(out)
}

fn number(scopes: &[&Dict], key: &str, tok: &str, depth: usize) -> Result<f64, DictError> {
    if depth > 16 {
        return Err(DictError::NotNumber(
            key.to_string(),
            format!("`{tok}` refers to itself"),
        ));
    }
    if let Some(body) = tok.strip_prefix("#eval{").and_then(|b| b.strip_suffix('}')) {
        let mut p = Expr {
            s: body.as_bytes(),
            i: 0,
            scopes,
            key,
            depth,
        };
        let v = p.sum()?;
        p.ws();
        if p.i != p.s.len() {
            return Err(DictError::NotNumber(
                key.to_string(),
                format!("cannot evaluate `{body}`"),
            ));
        }
        return Ok(v);
    }
    if let Some(name) = tok.strip_prefix('$') {
        let name = name.trim_matches(|c| c == '{' || c == '}');
        let v = scopes
            .iter()
            .rev()
            .find_map(|d| d.value(name))
            .ok_or_else(|| DictError::Undefined(key.to_string(), name.to_string()))?;
        return match v {
            [one] => number(scopes, key, one, depth + 1),
            _ => Err(DictError::NotNumber(
                key.to_string(),
                format!("${name} is not a single value"),
            )),
        };
    }
    tok.parse()
        .map_err(|_| DictError::NotNumber(key.to_string(), format!("`{tok}`")))
}

/// `#eval` arithmetic: + - * / and parentheses over numbers and `$names`.
struct Expr<'a> {
    s: &'a [u8],
    i: usize,
    scopes: &'a [&'a Dict],
    key: &'a str,
    depth: usize,
}

impl Expr<'_> {
    fn ws(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }

    fn sum(&mut self) -> Result<f64, DictError> {
        let mut v = self.product()?;
        loop {
            self.ws();
            match self.s.get(self.i) {
                Some(b'+') => {
                    self.i += 1;
                    v += self.product()?;
                }
                Some(b'-') => {
                    self.i += 1;
                    v -= self.product()?;
                }
                _ => return Ok(v),
            }
        }
    }

    fn product(&mut self) -> Result<f64, DictError> {
        let mut v = self.atom()?;
        loop {
            self.ws();
            match self.s.get(self.i) {
                Some(b'*') => {
                    self.i += 1;
                    v *= self.atom()?;
                }
                Some(b'/') => {
                    self.i += 1;
                    v /= self.atom()?;
                }
                _ => return Ok(v),
            }
        }
    }

    fn atom(&mut self) -> Result<f64, DictError> {
        self.ws();
        let bad = |s: &Self| {
            DictError::NotNumber(
                s.key.to_string(),
                format!("cannot evaluate `{}`", String::from_utf8_lossy(s.s)),
            )
        };
        match self.s.get(self.i) {
            Some(b'(') => {
                self.i += 1;
                let v = self.sum()?;
                self.ws();
                if self.s.get(self.i) != Some(&b')') {
                    return Err(bad(self));
                }
                self.i += 1;
                Ok(v)
            }
            Some(b'-') => {
                self.i += 1;
                Ok(-self.atom()?)
            }
            Some(b'+') => {
                self.i += 1;
                self.atom()
            }
            Some(b'$') => {
                let start = self.i;
                self.i += 1;
                while self.i < self.s.len()
                    && (self.s[self.i].is_ascii_alphanumeric()
                        || self.s[self.i] == b'_'
                        || self.s[self.i] == b'.')
                {
                    self.i += 1;
                }
                let name = std::str::from_utf8(&self.s[start..self.i]).expect("ascii");
                number(self.scopes, self.key, name, self.depth + 1)
            }
            Some(_) => {
                let start = self.i;
                while self.i < self.s.len()
                    && (self.s[self.i].is_ascii_digit()
                        || matches!(self.s[self.i], b'.' | b'e' | b'E')
                        || ((self.s[self.i] == b'-' || self.s[self.i] == b'+')
                            && self.i > start
                            && matches!(self.s[self.i - 1], b'e' | b'E')))
                {
                    self.i += 1;
                }
                let text = std::str::from_utf8(&self.s[start..self.i]).expect("ascii");
                text.parse().map_err(|_| bad(self))
            }
            None => Err(bad(self)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CASE: &str = r#"
FoamFile { version 2.0; class dictionary; object dynamicMeshDict; }
appliedForce    4;    // N
bodyMass        62.832;
/* a block
   comment */
motionSolverLibs (sixDoFRigidBodyMotion);
sixDoFRigidBodyMotionCoeffs
{
    mass            $bodyMass;
    g               (#eval{ $appliedForce / $bodyMass } 0 -0);
    rhoInf          1e3;
    constraints { a { sixDoFRigidBodyMotionConstraint line; direction (1 0 0); } }
}
"#;

    #[test]
    fn reads_references_and_eval() {
        let d = parse(CASE).unwrap();
        let coeffs = d.dict("sixDoFRigidBodyMotionCoeffs").unwrap();
        let scopes = [&d, coeffs];
        assert_eq!(numbers(&scopes, "mass").unwrap(), vec![62.832]);
        let g = numbers(&scopes, "g").unwrap();
        assert!((g[0] - 4.0 / 62.832).abs() < 1e-15 && g[1] == 0.0 && g.len() == 3);
        assert_eq!(numbers(&scopes, "rhoInf").unwrap(), vec![1000.0]);
        assert!(coeffs.dict("constraints").unwrap().dict("a").is_some());
    }

    #[test]
    fn eval_precedence_and_errors() {
        let d = parse("a 2; b #eval{ 1 + $a * (3 - 1) / 4 }; c $missing; e #eval{ 1 + };").unwrap();
        assert_eq!(numbers(&[&d], "b").unwrap(), vec![2.0]);
        assert_eq!(
            numbers(&[&d], "c"),
            Err(DictError::Undefined("c".into(), "missing".into()))
        );
        assert!(numbers(&[&d], "e").is_err());
        assert_eq!(numbers(&[&d], "zz"), Err(DictError::Missing("zz".into())));
        assert_eq!(parse("a { b 1;"), Err(DictError::Eof));
    }
}
