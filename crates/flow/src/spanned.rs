//! A small RON reader that keeps byte spans.
//!
//! `ron`'s serde errors only point at the parser cursor and there is no `Spanned<T>`, so the
//! loader reads pipeline files with this scanner first: it records where every node, field and
//! value starts and ends, which lets every later diagnostic (unknown kind, bad port, cycle, bad
//! parameter) point at the exact text. Values are not interpreted beyond what the loader needs;
//! node parameters are handed to `ron` itself as text.

use std::ops::Range;

/// A RON value with the byte range it covers in the source.
#[derive(Clone, Debug, PartialEq)]
pub struct SValue {
    pub span: Range<usize>,
    pub kind: SKind,
}

/// A struct field or map entry key with its span.
#[derive(Clone, Debug, PartialEq)]
pub struct SField {
    pub name: String,
    pub name_span: Range<usize>,
    pub value: SValue,
}

#[derive(Clone, Debug, PartialEq)]
pub enum SKind {
    /// A string literal, unescaped.
    Str(String),
    /// A number, as written.
    Num(String),
    /// A char literal.
    Char(char),
    /// A bare identifier: `true`, `None`, an enum unit variant, `inf`.
    Ident(String),
    /// `Name(a: 1, b: 2)` or `(a: 1)`.
    Struct {
        name: Option<String>,
        fields: Vec<SField>,
    },
    /// `Name(1, 2)`, `(1, 2)`, `Some(1)`, `()`.
    Tuple {
        name: Option<String>,
        items: Vec<SValue>,
    },
    /// `[1, 2]`.
    List(Vec<SValue>),
    /// `{ k: v }`.
    Map(Vec<(SValue, SValue)>),
}

impl SValue {
    /// The string content when this is a string literal.
    pub fn as_str(&self) -> Option<&str> {
        match &self.kind {
            SKind::Str(s) => Some(s),
            _ => None,
        }
    }
    /// Finds the value at a dotted field path (`a.b.0`) inside structs, maps and sequences.
    pub fn find_path(&self, path: &str) -> Option<(&SValue, Option<Range<usize>>)> {
        let mut cur = self;
        let mut name_span = None;
        for part in path.split('.').filter(|p| !p.is_empty()) {
            match &cur.kind {
                SKind::Struct { fields, .. } => {
                    let f = fields.iter().find(|f| f.name == part)?;
                    name_span = Some(f.name_span.clone());
                    cur = &f.value;
                }
                SKind::Map(entries) => {
                    let (k, v) = entries.iter().find(|(k, _)| key_text(k) == part)?;
                    name_span = Some(k.span.clone());
                    cur = v;
                }
                SKind::List(items) | SKind::Tuple { items, .. } => {
                    let i: usize = part.parse().ok()?;
                    cur = items.get(i)?;
                    name_span = None;
                }
                _ => return None,
            }
        }
        Some((cur, name_span))
    }
}

/// The text of a map key: string content, or the identifier/number as written.
pub fn key_text(v: &SValue) -> String {
    match &v.kind {
        SKind::Str(s) | SKind::Num(s) | SKind::Ident(s) => s.clone(),
        SKind::Char(c) => c.to_string(),
        _ => String::new(),
    }
}

/// A RON syntax error at a byte offset.
#[derive(Clone, Debug, PartialEq)]
pub struct ScanError {
    pub message: String,
    pub offset: usize,
}

/// Parses one RON value (with optional `#![enable(...)]` attributes before it) spanning the
/// whole text.
pub fn parse(src: &str) -> Result<SValue, ScanError> {
    let mut p = Parser {
        src,
        b: src.as_bytes(),
        pos: 0,
    };
    p.skip_ws()?;
    while p.peek() == Some(b'#') {
        p.skip_attribute()?;
        p.skip_ws()?;
    }
    let v = p.value(0)?;
    p.skip_ws()?;
    if p.pos < p.b.len() {
        return Err(p.err("unexpected text after the end of the value"));
    }
    Ok(v)
}

/// 1-based line and column (in characters) of a byte offset.
pub fn line_col(src: &str, offset: usize) -> (usize, usize) {
    let offset = floor_char_boundary(src, offset.min(src.len()));
    let before = &src[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map(|i| i + 1).unwrap_or(0);
    (line, src[line_start..offset].chars().count() + 1)
}

/// The byte offset of a 1-based line and character column (clamped to the text).
pub fn offset_of(src: &str, line: usize, column: usize) -> usize {
    let mut start = 0;
    for _ in 1..line.max(1) {
        match src[start..].find('\n') {
            Some(i) => start += i + 1,
            None => return src.len(),
        }
    }
    let line_text = &src[start..];
    let line_end = line_text.find('\n').unwrap_or(line_text.len());
    let col_bytes = line_text[..line_end]
        .char_indices()
        .nth(column.saturating_sub(1))
        .map(|(i, _)| i)
        .unwrap_or(line_end);
    start + col_bytes
}

fn floor_char_boundary(s: &str, mut i: usize) -> usize {
    while i > 0 && !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// Writes `s` as a RON string literal.
pub fn quote(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{{{:x}}}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

const MAX_DEPTH: usize = 128;

struct Parser<'a> {
    src: &'a str,
    b: &'a [u8],
    pos: usize,
}

impl Parser<'_> {
    fn err(&self, message: impl Into<String>) -> ScanError {
        ScanError {
            message: message.into(),
            offset: self.pos,
        }
    }
    fn peek(&self) -> Option<u8> {
        self.b.get(self.pos).copied()
    }
    fn skip_ws(&mut self) -> Result<(), ScanError> {
        loop {
            match self.peek() {
                Some(c) if c.is_ascii_whitespace() => self.pos += 1,
                Some(b'/') if self.b.get(self.pos + 1) == Some(&b'/') => {
                    while let Some(c) = self.peek() {
                        if c == b'\n' {
                            break;
                        }
                        self.pos += 1;
                    }
                }
                Some(b'/') if self.b.get(self.pos + 1) == Some(&b'*') => {
                    let start = self.pos;
                    self.pos += 2;
                    let mut depth = 1;
                    while depth > 0 {
                        match self.peek() {
                            None => {
                                self.pos = start;
                                return Err(self.err("unclosed block comment"));
                            }
                            Some(b'*') if self.b.get(self.pos + 1) == Some(&b'/') => {
                                depth -= 1;
                                self.pos += 2;
                            }
                            Some(b'/') if self.b.get(self.pos + 1) == Some(&b'*') => {
                                depth += 1;
                                self.pos += 2;
                            }
                            Some(_) => self.pos += 1,
                        }
                    }
                }
                _ => return Ok(()),
            }
        }
    }
    fn skip_attribute(&mut self) -> Result<(), ScanError> {
        // `#![enable(implicit_some)]`: skipped, ron sees the params text without it.
        let start = self.pos;
        while let Some(c) = self.peek() {
            self.pos += 1;
            if c == b']' {
                return Ok(());
            }
        }
        self.pos = start;
        Err(self.err("unclosed attribute `#![...]`"))
    }
    fn expect(&mut self, c: u8, what: &str) -> Result<(), ScanError> {
        self.skip_ws()?;
        if self.peek() == Some(c) {
            self.pos += 1;
            Ok(())
        } else {
            Err(self.err(format!("expected {what}, found {}", self.found())))
        }
    }
    fn found(&self) -> String {
        match self.src[self.pos..].chars().next() {
            None => "the end of the file".to_string(),
            Some(c) => format!("`{c}`"),
        }
    }
    fn ident(&mut self) -> Option<String> {
        let start = self.pos;
        // raw identifiers r#name
        if self.b[self.pos..].starts_with(b"r#")
            && self
                .b
                .get(self.pos + 2)
                .is_some_and(|c| c.is_ascii_alphabetic() || *c == b'_')
        {
            self.pos += 2;
        }
        let id_start = self.pos;
        match self.peek() {
            Some(c) if c.is_ascii_alphabetic() || c == b'_' => {}
            _ => {
                self.pos = start;
                return None;
            }
        }
        while let Some(c) = self.peek() {
            if c.is_ascii_alphanumeric() || c == b'_' {
                self.pos += 1;
            } else {
                break;
            }
        }
        Some(self.src[id_start..self.pos].to_string())
    }

    fn value(&mut self, depth: usize) -> Result<SValue, ScanError> {
        if depth > MAX_DEPTH {
            return Err(self.err("values are nested too deeply"));
        }
        self.skip_ws()?;
        let start = self.pos;
        let kind = match self.peek() {
            None => return Err(self.err("expected a value, found the end of the file")),
            Some(b'"') => SKind::Str(self.string()?),
            Some(b'r')
                if matches!(self.b.get(self.pos + 1), Some(b'"') | Some(b'#'))
                    && self.raw_string_ahead() =>
            {
                SKind::Str(self.raw_string()?)
            }
            Some(b'b') if self.b.get(self.pos + 1) == Some(&b'"') => {
                self.pos += 1;
                SKind::Str(self.string()?)
            }
            Some(b'\'') => SKind::Char(self.char_lit()?),
            Some(b'[') => {
                self.pos += 1;
                let mut items = Vec::new();
                loop {
                    self.skip_ws()?;
                    if self.peek() == Some(b']') {
                        self.pos += 1;
                        break;
                    }
                    items.push(self.value(depth + 1)?);
                    self.skip_ws()?;
                    match self.peek() {
                        Some(b',') => self.pos += 1,
                        Some(b']') => {}
                        _ => {
                            return Err(
                                self.err(format!("expected `,` or `]`, found {}", self.found()))
                            )
                        }
                    }
                }
                SKind::List(items)
            }
            Some(b'{') => {
                self.pos += 1;
                let mut entries = Vec::new();
                loop {
                    self.skip_ws()?;
                    if self.peek() == Some(b'}') {
                        self.pos += 1;
                        break;
                    }
                    let k = self.value(depth + 1)?;
                    self.expect(b':', "`:` after a map key")?;
                    let v = self.value(depth + 1)?;
                    entries.push((k, v));
                    self.skip_ws()?;
                    match self.peek() {
                        Some(b',') => self.pos += 1,
                        Some(b'}') => {}
                        _ => {
                            return Err(
                                self.err(format!("expected `,` or `}}`, found {}", self.found()))
                            )
                        }
                    }
                }
                SKind::Map(entries)
            }
            Some(b'(') => self.parens(None, depth)?,
            Some(c) if c.is_ascii_digit() || c == b'-' || c == b'+' || c == b'.' => {
                SKind::Num(self.number()?)
            }
            Some(c) if c.is_ascii_alphabetic() || c == b'_' => {
                let name = self
                    .ident()
                    .ok_or_else(|| self.err("expected an identifier"))?;
                let after = self.pos;
                self.skip_ws()?;
                if self.peek() == Some(b'(') {
                    self.parens(Some(name), depth)?
                } else {
                    self.pos = after;
                    SKind::Ident(name)
                }
            }
            Some(_) => return Err(self.err(format!("expected a value, found {}", self.found()))),
        };
        Ok(SValue {
            span: start..self.pos,
            kind,
        })
    }

    /// After an optional name: `(` struct fields or tuple items `)`.
    fn parens(&mut self, name: Option<String>, depth: usize) -> Result<SKind, ScanError> {
        self.expect(b'(', "`(`")?;
        self.skip_ws()?;
        if self.peek() == Some(b')') {
            self.pos += 1;
            return Ok(SKind::Tuple {
                name,
                items: Vec::new(),
            });
        }
        // A struct when the first item is `ident :` (but not `ident ::`).
        let save = self.pos;
        let is_struct = match self.ident() {
            Some(_) => {
                self.skip_ws()?;
                let r = self.peek() == Some(b':') && self.b.get(self.pos + 1) != Some(&b':');
                self.pos = save;
                r
            }
            None => false,
        };
        if is_struct {
            let mut fields: Vec<SField> = Vec::new();
            loop {
                self.skip_ws()?;
                if self.peek() == Some(b')') {
                    self.pos += 1;
                    break;
                }
                let ns = self.pos;
                let fname = self.ident().ok_or_else(|| {
                    self.err(format!("expected a field name, found {}", self.found()))
                })?;
                let name_span = ns..self.pos;
                if fields.iter().any(|f| f.name == fname) {
                    self.pos = ns;
                    return Err(self.err(format!("field `{fname}` is given twice")));
                }
                self.expect(b':', "`:` after a field name")?;
                let value = self.value(depth + 1)?;
                fields.push(SField {
                    name: fname,
                    name_span,
                    value,
                });
                self.skip_ws()?;
                match self.peek() {
                    Some(b',') => self.pos += 1,
                    Some(b')') => {}
                    _ => {
                        return Err(self.err(format!("expected `,` or `)`, found {}", self.found())))
                    }
                }
            }
            Ok(SKind::Struct { name, fields })
        } else {
            let mut items = Vec::new();
            loop {
                self.skip_ws()?;
                if self.peek() == Some(b')') {
                    self.pos += 1;
                    break;
                }
                items.push(self.value(depth + 1)?);
                self.skip_ws()?;
                match self.peek() {
                    Some(b',') => self.pos += 1,
                    Some(b')') => {}
                    _ => {
                        return Err(self.err(format!("expected `,` or `)`, found {}", self.found())))
                    }
                }
            }
            Ok(SKind::Tuple { name, items })
        }
    }

    fn number(&mut self) -> Result<String, ScanError> {
        let start = self.pos;
        if matches!(self.peek(), Some(b'-') | Some(b'+')) {
            self.pos += 1;
        }
        // `-inf`, `+NaN`
        if self.peek().is_some_and(|c| c.is_ascii_alphabetic()) {
            let _ = self.ident();
            return Ok(self.src[start..self.pos].to_string());
        }
        let mut prev = 0u8;
        while let Some(c) = self.peek() {
            let ok = c.is_ascii_alphanumeric()
                || c == b'_'
                || c == b'.'
                || ((c == b'+' || c == b'-') && (prev == b'e' || prev == b'E'));
            if !ok {
                break;
            }
            prev = c;
            self.pos += 1;
        }
        let text = &self.src[start..self.pos];
        if !text.bytes().any(|c| c.is_ascii_digit()) {
            self.pos = start;
            return Err(self.err(format!("expected a value, found {}", self.found())));
        }
        Ok(text.to_string())
    }

    fn raw_string_ahead(&self) -> bool {
        let mut i = self.pos + 1;
        while self.b.get(i) == Some(&b'#') {
            i += 1;
        }
        self.b.get(i) == Some(&b'"')
    }

    fn raw_string(&mut self) -> Result<String, ScanError> {
        let start = self.pos;
        self.pos += 1;
        let mut hashes = 0;
        while self.peek() == Some(b'#') {
            hashes += 1;
            self.pos += 1;
        }
        self.pos += 1; // the quote
        let body_start = self.pos;
        let closing: String = std::iter::once('"')
            .chain(std::iter::repeat_n('#', hashes))
            .collect();
        match self.src[body_start..].find(&closing) {
            Some(i) => {
                self.pos = body_start + i + closing.len();
                Ok(self.src[body_start..body_start + i].to_string())
            }
            None => {
                self.pos = start;
                Err(self.err("unclosed raw string"))
            }
        }
    }

    fn string(&mut self) -> Result<String, ScanError> {
        let start = self.pos;
        self.pos += 1;
        let mut out = String::new();
        loop {
            let rest = &self.src[self.pos..];
            let Some(c) = rest.chars().next() else {
                self.pos = start;
                return Err(self.err("unclosed string"));
            };
            self.pos += c.len_utf8();
            match c {
                '"' => return Ok(out),
                '\\' => out.push(self.escape()?),
                c => out.push(c),
            }
        }
    }

    fn escape(&mut self) -> Result<char, ScanError> {
        let Some(c) = self.peek() else {
            return Err(self.err("unfinished escape sequence"));
        };
        self.pos += 1;
        Ok(match c {
            b'"' => '"',
            b'\'' => '\'',
            b'\\' => '\\',
            b'/' => '/',
            b'n' => '\n',
            b'r' => '\r',
            b't' => '\t',
            b'0' => '\0',
            b'b' => '\u{8}',
            b'f' => '\u{c}',
            b'x' => {
                let h = self.src.get(self.pos..self.pos + 2).unwrap_or("");
                let v = u32::from_str_radix(h, 16).map_err(|_| self.err("bad `\\x` escape"))?;
                self.pos += 2;
                char::from_u32(v).ok_or_else(|| self.err("bad `\\x` escape"))?
            }
            b'u' => {
                let rest = &self.src[self.pos..];
                let (digits, used) = if let Some(r) = rest.strip_prefix('{') {
                    let end = r.find('}').ok_or_else(|| self.err("bad `\\u` escape"))?;
                    (&r[..end], end + 2)
                } else {
                    (rest.get(..4).unwrap_or(""), 4)
                };
                let v =
                    u32::from_str_radix(digits, 16).map_err(|_| self.err("bad `\\u` escape"))?;
                self.pos += used;
                char::from_u32(v).ok_or_else(|| self.err("bad `\\u` escape"))?
            }
            _ => {
                self.pos -= 1;
                return Err(self.err("unknown escape sequence"));
            }
        })
    }

    fn char_lit(&mut self) -> Result<char, ScanError> {
        let start = self.pos;
        self.pos += 1;
        let Some(c) = self.src[self.pos..].chars().next() else {
            self.pos = start;
            return Err(self.err("unclosed char literal"));
        };
        self.pos += c.len_utf8();
        let c = if c == '\\' { self.escape()? } else { c };
        if self.peek() != Some(b'\'') {
            self.pos = start;
            return Err(self.err("unclosed char literal"));
        }
        self.pos += 1;
        Ok(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_cover_fields_and_values() {
        let src = "Graph(nodes: { \"a\": (kind: \"x.y\", params: (n: 3)) }) // end";
        let v = parse(src).unwrap();
        let (kind, _) = v.find_path("nodes.a.kind").unwrap();
        assert_eq!(&src[kind.span.clone()], "\"x.y\"");
        assert_eq!(kind.as_str(), Some("x.y"));
        let (n, name) = v.find_path("nodes.a.params.n").unwrap();
        assert_eq!(&src[n.span.clone()], "3");
        assert_eq!(&src[name.unwrap()], "n");
    }

    #[test]
    fn syntax_errors_have_offsets() {
        let src = "(a: 1,\n b: [1, 2 3])";
        let e = parse(src).unwrap_err();
        assert_eq!(line_col(src, e.offset), (2, 11));
        let e = parse("(a: \"open)").unwrap_err();
        assert_eq!(e.offset, 4);
        assert!(parse("(a: 1, a: 2)").unwrap_err().message.contains("twice"));
    }

    #[test]
    fn strings_raw_strings_numbers_comments() {
        let v = parse("[\"a\\n\\u{41}\", r#\"x\"y\"#, -1.5e-3, 0x1F, 'c', /* c /* nested */ */ None, Some(2), ()]")
            .unwrap();
        let SKind::List(items) = &v.kind else {
            panic!("not a list")
        };
        assert_eq!(items[0].as_str(), Some("a\nA"));
        assert_eq!(items[1].as_str(), Some("x\"y"));
        assert_eq!(items[2].kind, SKind::Num("-1.5e-3".into()));
        assert_eq!(items[3].kind, SKind::Num("0x1F".into()));
        assert_eq!(items[4].kind, SKind::Char('c'));
        assert_eq!(items[5].kind, SKind::Ident("None".into()));
        assert!(
            matches!(&items[6].kind, SKind::Tuple { name: Some(n), items } if n == "Some" && items.len() == 1)
        );
        assert!(matches!(&items[7].kind, SKind::Tuple { name: None, items } if items.is_empty()));
    }

    #[test]
    fn line_col_round_trip() {
        let src = "ab\ncdé\nf";
        for off in [0, 1, 3, 5, 8] {
            let (l, c) = line_col(src, off);
            assert_eq!(offset_of(src, l, c), off);
        }
        assert_eq!(line_col(src, 8), (3, 1));
        assert_eq!(quote("a\"b\\"), "\"a\\\"b\\\\\"");
    }
}
